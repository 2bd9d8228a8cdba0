"""Where the tools write: every output path checked before any work starts, every result written
atomically (to a temporary file in the same folder, synced, then renamed into place), so that a run
never ends in a traceback after its work, a reader never sees half a file, and a write that fails
all the same (a disk filled meanwhile) leaves what was there before and says so in one line.

Before any work an output file must: not be an input of the same run, nor an existing special
file (a device, a pipe, a folder); not exist unless the tool was asked to overwrite; have a name,
and the names of its siblings (its temporary file, its ".partial" and its lock,
tric_sim.tools.claims), that the file system takes; and go into a folder that can hold new files,
with room for the expected size. A result is moved into place without replacing a file that
appeared meanwhile unless asked to (atomic_path's replace), and is readable as any new file
(mode 0666 less the umask).

The checks try the folder for real (a probe file is created and removed in the nearest folder that
exists): permission bits alone would pass /proc, or anything else, for root.
"""

import contextlib
import errno
import os
import pathlib
import shutil
import uuid
from typing import cast

from tric_sim.tools.claims import FOLDER_LOCK

#: The longest file name when the file system does not say (bytes; Linux's NAME_MAX).
DEFAULT_NAME_MAX = 255
#: The suffix of the file that keeps a run's finished items until its result is written
#: (tric-eval's --json file + PARTIAL_SUFFIX).
PARTIAL_SUFFIX = ".partial"
#: The temporary files of the writes in progress in this process (atomic_path).
_temporaries: set[pathlib.Path] = set()
#: renameat2(2)'s flag: fail with EEXIST rather than replace the target.
RENAME_NOREPLACE = 1
_AT_FDCWD = -100


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


def nearest_existing(path: pathlib.Path) -> pathlib.Path:
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
    existing = nearest_existing(path.parent)
    name_max = _name_max(existing)
    siblings = (path.name, _temporary_name(path), path.name + PARTIAL_SUFFIX, f".{path.name}.lock")
    longest = max(siblings, key=lambda name: len(name.encode()))
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
            f"{where} cannot be written: {folder} has {size_text(free)} free, "
            f"{size_text(expected_bytes)} are needed"
        )


def size_text(size: int) -> str:
    """A size in bytes as people read it: "512 bytes", "20 kB", "1.2 MB", "3.4 GB"."""
    if size < 1000:
        return f"{size} bytes"
    for unit, scale in (("kB", 1e3), ("MB", 1e6), ("GB", 1e9), ("TB", 1e12)):
        if size < scale * 1000 or unit == "TB":
            return f"{size / scale:.{0 if size >= scale * 100 else 1}f} {unit}"
    return f"{size} bytes"  # not reached: TB takes every larger size


def _check_name_lengths(path: pathlib.Path, what: str) -> None:
    """ValueError if a part of path is longer than its file system takes."""
    name_max = _name_max(nearest_existing(path))
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
    existing = nearest_existing(path)
    if not existing.is_dir():
        raise ValueError(f"{where} cannot be used: {existing} is a file, not a folder")
    if must_be_empty and existing == path.absolute():
        entries = sorted(entry.name for entry in path.iterdir() if entry.name != FOLDER_LOCK)
        if entries:
            shown = ", ".join(entries[:3]) + (
                f" and {len(entries) - 3} more" if len(entries) > 3 else ""
            )
            raise ValueError(f"{where} is not empty ({shown})")
    _probe_folder(existing, where)
    _check_room(existing, where, expected_bytes)
    return path


@contextlib.contextmanager
def atomic_path(path, replace: bool = True):
    """A context manager giving a temporary path, next to path with the same suffix, to write the
    result to; on a normal exit it is synced, made readable as any new file (mode 0666 less the
    umask) and renamed onto path (replacing a file there unless replace is False), the folder
    synced after; on an exception removed. The folder of path is created if missing. A write that
    fails (OSError: a full disk, a folder removed) raises WriteFailed naming path and the cause,
    and leaves any earlier file at path as it was. With replace False, a file that appeared at
    path meanwhile is left as it is: the result goes to a free name beside it (kept_name), and
    WriteFailed names both."""
    path = pathlib.Path(path)
    temporary = path.with_name(_temporary_name(path))
    _temporaries.add(temporary)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        yield temporary
        with open(temporary, "rb+") as written:
            os.fsync(written.fileno())
        os.chmod(temporary, 0o666 & ~_umask())
        if replace:
            os.replace(temporary, path)
        else:
            _move_without_replacing(temporary, path)
        _sync_folder(path.parent)
    except WriteFailed:
        raise
    except OSError as error:
        raise WriteFailed(
            error.errno, f"{path} could not be written ({error.strerror or error})"
        ) from None
    finally:
        temporary.unlink(missing_ok=True)
        _temporaries.discard(temporary)


def _sync_folder(folder: pathlib.Path) -> None:
    descriptor = os.open(folder, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def _move_without_replacing(temporary: pathlib.Path, path: pathlib.Path) -> None:
    """Rename temporary onto path unless a file is there; if one is, to kept_name(path), and
    WriteFailed naming both."""
    try:
        rename_without_replacing(temporary, path)
        return
    except FileExistsError:
        pass
    for kept in kept_names(path):
        try:
            rename_without_replacing(temporary, kept)
        except FileExistsError:
            continue
        _sync_folder(path.parent)
        raise WriteFailed(
            errno.EEXIST,
            f"{path} appeared while this run worked (another program wrote it): it is left as "
            f"it was, and this run's result is {kept}",
        )
    raise WriteFailed(errno.EEXIST, f"{path} and every name kept_names gives for it exist")


def kept_names(path: pathlib.Path):
    """The names a result goes to when path was taken meanwhile: <stem>.new<suffix>, then
    <stem>.new2<suffix>, ... (at most 100)."""
    for k in range(1, 101):
        yield path.with_name(f"{path.stem}.new{k if k > 1 else ''}{path.suffix}")


def rename_without_replacing(source: pathlib.Path, target: pathlib.Path) -> None:
    """Rename source to target, FileExistsError if target exists: renameat2 with RENAME_NOREPLACE
    where the C library and the file system have it, else a hard link (which fails on an existing
    target) and the source unlinked; on a file system with neither, a look before the rename (not
    atomic: the one case where a file appearing in between is replaced)."""
    renameat2, get_errno = _renameat2()
    if renameat2 is not None:
        done = renameat2(
            _AT_FDCWD, os.fsencode(source), _AT_FDCWD, os.fsencode(target), RENAME_NOREPLACE
        )
        if done == 0:
            return
        code = get_errno()
        if code not in (errno.EINVAL, errno.ENOSYS, errno.EOPNOTSUPP):
            raise OSError(code, os.strerror(code), str(target))
    try:
        os.link(source, target)
    except OSError as error:
        if error.errno not in (errno.EPERM, errno.EOPNOTSUPP, errno.ENOSYS):
            raise
        if os.path.lexists(target):
            raise FileExistsError(errno.EEXIST, os.strerror(errno.EEXIST), str(target)) from None
        os.rename(source, target)
        return
    os.unlink(source)


def _renameat2() -> tuple:
    """(the C library's renameat2 or None where it has none, ctypes.get_errno); ctypes is imported
    here, at the first use, as the tools import this module before they install their handling of
    interrupts."""
    import ctypes

    return getattr(ctypes.CDLL(None, use_errno=True), "renameat2", None), ctypes.get_errno


def _umask() -> int:
    """This process's umask (read from /proc, else by setting it and back)."""
    try:
        for line in pathlib.Path("/proc/self/status").read_text().splitlines():
            if line.startswith("Umask:"):
                return int(line.split()[1], 8)
    except (OSError, ValueError, IndexError):
        pass
    mask = os.umask(0o022)
    os.umask(mask)
    return mask


def remove_temporaries() -> None:
    """Remove the temporary files of the writes in progress (a tool ending on a signal)."""
    for temporary in list(_temporaries):
        temporary.unlink(missing_ok=True)


def write_text_atomic(path, text: str, replace: bool = True) -> pathlib.Path:
    """Write text to path atomically (see atomic_path, and its replace); the path."""
    path = pathlib.Path(path)
    with atomic_path(path, replace) as temporary:
        temporary.write_text(text)
    return path
