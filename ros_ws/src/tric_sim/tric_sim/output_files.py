"""Where the tools write: every output path checked before any work starts, every result written
atomically (to a temporary file in the same folder, then renamed into place), so that a run never
ends in a traceback after its work, and a reader never sees half a file.

The checks try the folder for real (a probe file is created and removed in the nearest folder that
exists): permission bits alone would pass /proc, or anything else, for root.
"""

import contextlib
import os
import pathlib
import uuid


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
    """path, or its nearest ancestor that exists."""
    path = path.absolute()
    return next(candidate for candidate in (path, *path.parents) if candidate.exists())


def check_output_file(path, suffixes=(), what: str = "output file") -> pathlib.Path:
    """path as a Path if a file can be written there (its missing folders created on writing);
    ValueError naming what and why otherwise: the path is a folder, its suffix is not one of
    suffixes (when given), or the folder it goes in cannot hold new files. Creates nothing."""
    path = pathlib.Path(path)
    where = f"{what} {path}"
    if not str(path) or path.name in ("", ".", ".."):
        raise ValueError(f"{where} names no file")
    if suffixes and path.suffix not in suffixes:
        raise ValueError(f"{where} must end in {' or '.join(suffixes)}")
    if path.is_dir():
        raise ValueError(f"{where} is a folder; give a file path")
    existing = _nearest_existing(path.parent)
    if not existing.is_dir():
        raise ValueError(f"{where} cannot be written: {existing} is a file, not a folder")
    _probe_folder(existing, where)
    return path


def check_output_folder(
    path, what: str = "output folder", must_be_empty: bool = False
) -> pathlib.Path:
    """path as a Path if files can be written into it (created on writing if missing); ValueError
    naming what and why otherwise: it is a file, it cannot hold new files, or (must_be_empty) it
    holds files already. Creates nothing."""
    path = pathlib.Path(path)
    where = f"{what} {path}"
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
    return path


@contextlib.contextmanager
def atomic_path(path):
    """A context manager giving a temporary path, next to path with the same suffix, to write the
    result to; on a normal exit it is synced and renamed onto path (replacing any file there), on
    an exception removed. The folder of path is created if missing."""
    path = pathlib.Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.with_name(
        f".{path.stem}.{os.getpid()}-{uuid.uuid4().hex[:8]}.tmp{path.suffix}"
    )
    try:
        yield temporary
        with open(temporary, "rb+") as written:
            os.fsync(written.fileno())
        os.replace(temporary, path)
    finally:
        temporary.unlink(missing_ok=True)


def write_text_atomic(path, text: str) -> pathlib.Path:
    """Write text to path atomically (see atomic_path); the path."""
    path = pathlib.Path(path)
    with atomic_path(path) as temporary:
        temporary.write_text(text)
    return path
