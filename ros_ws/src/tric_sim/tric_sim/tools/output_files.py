"""Where the tools write: every output path checked before any work starts, every result written
atomically (to a temporary file in the same folder, synced, then renamed into place), so that a run
never ends in a traceback after its work, a reader never sees half a file, and a write that fails
all the same (a disk filled meanwhile) leaves what was there before and says so in one line.

Before any work an output file must: not be an input of the same run, nor an existing special
file (a device, a pipe, a folder); not exist unless the tool was asked to overwrite; have a name,
and a temporary sibling's name, that the file system takes; and go into a folder that can hold new
files, with room for the expected size.

The checks try the folder for real (a probe file is created and removed in the nearest folder that
exists): permission bits alone would pass /proc, or anything else, for root.
"""

import contextlib
import os
import pathlib
import shutil
import uuid
from typing import cast

#: The longest file name when the file system does not say (bytes; Linux's NAME_MAX).
DEFAULT_NAME_MAX = 255
#: The temporary files of the writes in progress in this process (atomic_path).
_temporaries: set[pathlib.Path] = set()


class WriteFailed(OSError):
    """A result that could not be written all the same (atomic_path); its text is one line naming
    the path and the cause, for a tool to print as its answer."""

    def __str__(self) -> str:
        # always set: atomic_path raises it as WriteFailed(errno, text)
        return cast(str, self.strerror)


def _probe_folder(folder: pathlib.Path, what: str) -> None:
    """ValueError unless a file can be created in the existing folder."""
    probe = folder / f".tric-probe-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    try:
        descriptor = os.open(probe, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600)
    except OSError as error:
        raise ValueError(
            f"{what} cannot be written: {folder} refuses new files ({error.strerror})"
        ) from None
    os.close(descriptor)
    probe.unlink()


def _nearest_existing(path: pathlib.Path) -> pathlib.Path:
    """path, or its nearest ancestor that exists (a name too long to look up counts as missing)."""
    for candidate in (path.absolute(), *path.absolute().parents):
        try:
            if candidate.exists():
                return candidate
        except OSError:
            continue
    return pathlib.Path(path.absolute().anchor)


def _name_max(folder: pathlib.Path) -> int:
    """The longest file name folder's file system takes, bytes."""
    try:
        return os.pathconf(folder, "PC_NAME_MAX")
    except (OSError, ValueError):
        return DEFAULT_NAME_MAX


def check_output_file(
    path,
    suffixes=(),
    what: str = "output file",
    *,
    inputs=(),
    overwrite: bool = True,
    expected_bytes: int = 0,
) -> pathlib.Path:
    """path as a Path if a file can be written there (its missing folders created on writing);
    ValueError naming what and why otherwise: the path names no file or a folder; its suffix is
    not one of suffixes (when given); it is one of inputs (paths this run reads) or an existing
    special file; it exists and overwrite is False; its name, or its temporary sibling's, is too
    long for the file system; the folder it goes in cannot hold new files, or has less than
    expected_bytes free. Creates nothing."""
    path = pathlib.Path(path)
    where = f"{what} {path}"
    if not str(path) or path.name in ("", ".", ".."):
        raise ValueError(f"{where} names no file")
    if suffixes and path.suffix not in suffixes:
        raise ValueError(f"{where} must end in {' or '.join(suffixes)}")
    _check_name_lengths(path.parent, what)
    existing = _nearest_existing(path.parent)
    name_max = _name_max(existing)
    longest = max(path.name, _temporary_name(path), key=lambda name: len(name.encode()))
    if len(longest.encode()) > name_max:
        raise ValueError(
            f"{what} {str(path)[:200]}: the name {longest[:80]}... is longer than the "
            f"{name_max} bytes the file system takes"
        )
    if path.is_dir():
        raise ValueError(f"{where} is a folder; give a file path")
    for source in inputs:
        if source and _same_file(path, pathlib.Path(source)):
            raise ValueError(f"{where} is an input of this run ({source}); give another path")
    if path.exists() and not path.is_file():
        raise ValueError(f"{where} exists and is not a regular file (a device, pipe or socket)")
    if path.exists() and not overwrite:
        raise ValueError(f"{where} exists; give --overwrite to replace it")
    if not existing.is_dir():
        raise ValueError(f"{where} cannot be written: {existing} is a file, not a folder")
    _probe_folder(existing, where)
    _check_room(existing, where, expected_bytes)
    return path


def _check_room(folder: pathlib.Path, where: str, expected_bytes: int) -> None:
    """ValueError unless folder's file system has expected_bytes free."""
    free = shutil.disk_usage(folder).free
    if free < expected_bytes:
        raise ValueError(
            f"{where} cannot be written: {folder} has {free / 1e6:.1f} MB free, "
            f"{expected_bytes / 1e6:.1f} MB are needed"
        )


def _check_name_lengths(path: pathlib.Path, what: str) -> None:
    """ValueError if a part of path is longer than its file system takes."""
    name_max = _name_max(_nearest_existing(path))
    for part in path.parts:
        if len(part.encode()) > name_max:
            raise ValueError(
                f"{what} {str(path)[:200]}: the name {part[:80]}... is longer than the "
                f"{name_max} bytes the file system takes"
            )


def _same_file(a: pathlib.Path, b: pathlib.Path) -> bool:
    """Whether a and b name the same existing file (links and relative paths resolved)."""
    try:
        return a.exists() and b.exists() and os.path.samefile(a, b)
    except OSError:
        return False


def _temporary_name(path: pathlib.Path) -> str:
    """A fresh name, beside path, for the file that becomes path: short whatever path's name."""
    return f".tric-{uuid.uuid4().hex[:8]}.tmp{path.suffix}"


def check_output_folder(
    path, what: str = "output folder", must_be_empty: bool = False, expected_bytes: int = 0
) -> pathlib.Path:
    """path as a Path if files can be written into it (created on writing if missing); ValueError
    naming what and why otherwise: it is a file, it cannot hold new files, (must_be_empty) it
    holds files already, or it has less than expected_bytes free. Creates nothing."""
    path = pathlib.Path(path)
    where = f"{what} {str(path)[:200]}"
    _check_name_lengths(path, what)
    existing = _nearest_existing(path)
    if not existing.is_dir():
        raise ValueError(f"{where} cannot be used: {existing} is a file, not a folder")
    if must_be_empty and existing == path.absolute():
        entries = sorted(entry.name for entry in path.iterdir())
        if entries:
            shown = ", ".join(entries[:3]) + (
                f" and {len(entries) - 3} more" if len(entries) > 3 else ""
            )
            raise ValueError(f"{where} is not empty ({shown})")
    _probe_folder(existing, where)
    _check_room(existing, where, expected_bytes)
    return path


@contextlib.contextmanager
def atomic_path(path):
    """A context manager giving a temporary path, next to path with the same suffix, to write the
    result to; on a normal exit it is synced and renamed onto path (replacing any file there, the
    folder synced after), on an exception removed. The folder of path is created if missing. A
    write that fails (OSError: a full disk, a folder removed) raises WriteFailed naming path and
    the cause, and leaves any earlier file at path as it was."""
    path = pathlib.Path(path)
    temporary = path.with_name(_temporary_name(path))
    _temporaries.add(temporary)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        yield temporary
        with open(temporary, "rb+") as written:
            os.fsync(written.fileno())
        os.replace(temporary, path)
        folder = os.open(path.parent, os.O_RDONLY)
        try:
            os.fsync(folder)
        finally:
            os.close(folder)
    except OSError as error:
        raise WriteFailed(
            error.errno, f"{path} could not be written ({error.strerror or error})"
        ) from None
    finally:
        temporary.unlink(missing_ok=True)
        _temporaries.discard(temporary)


def remove_temporaries() -> None:
    """Remove the temporary files of the writes in progress (a tool ending on a signal)."""
    for temporary in list(_temporaries):
        temporary.unlink(missing_ok=True)


def write_text_atomic(path, text: str) -> pathlib.Path:
    """Write text to path atomically (see atomic_path); the path."""
    path = pathlib.Path(path)
    with atomic_path(path) as temporary:
        temporary.write_text(text)
    return path
