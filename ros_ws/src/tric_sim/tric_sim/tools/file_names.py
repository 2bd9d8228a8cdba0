"""The files a run names after its items (a bag after its situation, a picture after its situation,
a model after its study variant), checked all together before any work (check_file_names): no two
items map to one file as the folder's file system compares names (ignoring case, or Unicode
normalization, where it does: found by trying), no name hidden (a leading dot), too long for the
file system (its siblings' suffixes included), or naming an input of the run. ROS-free."""

import os
import pathlib
import unicodedata
import uuid

from tric_sim.tools.output_files import check_output_file, nearest_existing
from tric_sim.tools.untrusted import quoted


def safe_stem(name: str) -> str:
    """The file stem the recorder names an episode's bag with: name with every character but
    letters, digits, "-", "_" and "." replaced by "_" ("episode" for an empty name)."""
    return "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "episode"


def name_folding(folder) -> tuple:
    """(whether the file system of folder, or of its nearest existing ancestor, takes names that
    differ in case for one file, whether it takes names that differ in Unicode normalization for
    one file), found by creating a file and looking it up under the other name."""
    existing = nearest_existing(pathlib.Path(folder))
    probe = f".tric-names-{uuid.uuid4().hex[:8]}-"
    tries = {"case": ("Ab", "aB"), "unicode": (unicodedata.normalize("NFC", "\u00e9"), "e\u0301")}
    folded = {}
    for kind, (made, looked_up) in tries.items():
        path = existing / (probe + made)
        try:
            descriptor = os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
        except OSError:  # not writable: the output checks name that
            folded[kind] = False
            continue
        os.close(descriptor)
        try:
            folded[kind] = (existing / (probe + looked_up)).exists()
        finally:
            path.unlink()
    return folded["case"], folded["unicode"]


def check_file_names(folder, files: dict, what: str, inputs=(), overwrite: bool = True) -> None:
    """ValueError naming the items, unless the files ({item name: file name in folder}) can all be
    written: no two the same file as folder's file system compares names (name_folding), none
    starting with ".", and each a file check_output_file takes (its length with its siblings',
    not an input of the run, not existing unless overwrite). what: what a file is ("bag",
    "model", ...)."""
    folder = pathlib.Path(folder)
    folds_case, folds_unicode = name_folding(folder)
    seen: dict[str, tuple] = {}
    for item, name in files.items():
        item = quoted(repr(item), 80)
        if name.startswith("."):
            raise ValueError(f"the {what} of {item} would be {name!r}, hidden by its leading dot")
        key = unicodedata.normalize("NFD", name) if folds_unicode else name
        key = key.casefold() if folds_case else key
        if key in seen:
            first, first_name = seen[key]
            how = "" if first_name == name else f" ({first_name} to its file system)"
            raise ValueError(
                f"the {what}s of {first} and {item} would be one file, "
                f"{str(folder / name)[:200]}{how}: rename one"
            )
        seen[key] = item, name
        check_output_file(
            folder / name, what=f"the {what} of {item}", inputs=inputs, overwrite=overwrite
        )
