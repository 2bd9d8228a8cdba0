"""One writer per output: a run claims every file and folder it will write before any work, so that
a second run naming the same output is refused at once, in one line naming the first run's PID,
instead of both writing it and one result being lost.

A claim is an exclusive flock(2) on a lock file: beside a file output (".<name>.lock"), inside a
folder output (FOLDER_LOCK). The lock file holds the PID of the run that holds it. The kernel
releases the lock when that process ends, however it ends (SIGKILL too), so a lock file left behind
claims nothing and the next run takes it over. A run removes its lock files when it ends
(tric_sim.tools.interrupts too, on a signal; and at any exit of the interpreter), and the folders
its claims created while still empty. Claims are held per process: claiming again what this process
holds is counted, not refused (a tool and the library code it calls may both claim one output).
ROS-free.
"""

import atexit
import errno
import fcntl
import os
import pathlib
import threading
import time

#: The lock file a folder output holds while a run writes into it.
FOLDER_LOCK = ".tric.lock"
#: How long a run waits for a lock's holder to have written its PID, s (it does so at once).
PID_WAIT_S = 0.5
#: The errors of a file system that takes no locks: a claim there holds nothing (the final
#: no-replace rename, tric_sim.tools.output_files.atomic_path, still protects finished files).
_NO_LOCKS = (errno.ENOLCK, errno.EOPNOTSUPP, errno.EINVAL)


class _Held:
    """A lock this process holds: its descriptor, how many claims share it, the folders made, and
    the process that made it (a forked child inherits the table, not the claims)."""

    def __init__(self, descriptor: int, made: list):
        self.descriptor, self.count, self.made = descriptor, 1, made
        self.pid = os.getpid()


_held: dict[pathlib.Path, _Held] = {}
_guard = threading.Lock()


def lock_path(output, folder: bool = False) -> pathlib.Path:
    """The lock file of a file output (".<name>.lock" beside it) or a folder output (FOLDER_LOCK
    in it), absolute."""
    output = pathlib.Path(output).absolute()
    return output / FOLDER_LOCK if folder else output.with_name(f".{output.name}.lock")


class Claim:
    """A held claim (claim()); release() it, or use it as a context manager."""

    def __init__(self, lock: pathlib.Path):
        self.lock = lock
        self._released = False

    def __enter__(self) -> "Claim":
        return self

    def __exit__(self, *_) -> None:
        self.release()

    def release(self) -> None:
        """Give the claim up (once); the last claim of a lock removes its file and the folders
        the claim made, if empty."""
        if self._released:
            return
        self._released = True
        with _guard:
            held = _held.get(self.lock)
            if held is None:
                return
            held.count -= 1
            if held.count > 0:
                return
            del _held[self.lock]
            self.lock.unlink(missing_ok=True)
            os.close(held.descriptor)
            for folder in reversed(held.made):
                try:
                    folder.rmdir()
                except OSError:  # not empty: the run wrote into it
                    break


def claim(output, what: str = "output", folder: bool = False) -> Claim:
    """Claim output (a file, or with folder a folder) for this run; ValueError in one line naming
    the PID of the run that holds it. Makes the missing folders the lock file goes in."""
    lock = lock_path(output, folder)
    with _guard:
        if lock in _held:
            _held[lock].count += 1
            return Claim(lock)
        made = _make_folders(lock.parent)
        try:
            descriptor = _lock(lock)
        except BlockingIOError:
            for made_folder in reversed(made):
                made_folder.rmdir()
            raise ValueError(
                f"{what} {str(output)[:200]} is being written by another run "
                f"({_holder(lock)}): wait for it to end, or give another path"
            ) from None
        _held[lock] = _Held(descriptor, made)
    return Claim(lock)


def _lock(lock: pathlib.Path) -> int:
    """A descriptor of lock holding its exclusive flock, this PID written in it; BlockingIOError
    if another process holds it."""
    while True:
        descriptor = os.open(lock, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError as error:
            if error.errno not in _NO_LOCKS:
                os.close(descriptor)
                raise
        try:  # its holder may have removed it meanwhile, and another made it anew: lock that one
            same = os.stat(lock).st_ino == os.fstat(descriptor).st_ino
        except FileNotFoundError:
            same = False
        if same:
            os.ftruncate(descriptor, 0)
            os.write(descriptor, f"{os.getpid()}\n".encode())
            return descriptor
        os.close(descriptor)


def _holder(lock: pathlib.Path) -> str:
    """ "PID <n>" of the process whose PID lock holds (it writes it just after locking)."""
    deadline = time.monotonic() + PID_WAIT_S
    while True:
        try:
            text = lock.read_bytes()[:32].decode(errors="replace").strip()
        except OSError:
            text = ""
        if text.isdigit() or time.monotonic() > deadline:
            return f"PID {text}" if text.isdigit() else "PID unknown"
        time.sleep(0.01)


def open_exclusive(path, what: str):
    """path opened for writing from its start (created, or truncated once locked), holding an
    exclusive flock until closed: a file one writer writes in place (a bag's ".part"), which
    another process holding it refuses with FileExistsError naming that process's PID."""
    descriptor = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o666)
    try:
        fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except BlockingIOError:
        holder = _flock_holder(descriptor)
        os.close(descriptor)
        raise FileExistsError(
            errno.EEXIST, f"{what} {path} is being written by another process ({holder})"
        ) from None
    except OSError as error:
        if error.errno not in _NO_LOCKS:
            os.close(descriptor)
            raise
    os.ftruncate(descriptor, 0)
    return os.fdopen(descriptor, "wb")


def _flock_holder(descriptor: int) -> str:
    """ "PID <n>" of the process holding the flock on descriptor's file (from /proc/locks)."""
    status = os.fstat(descriptor)
    file_id = f"{os.major(status.st_dev):02x}:{os.minor(status.st_dev):02x}:{status.st_ino}"
    try:
        locks = pathlib.Path("/proc/locks").read_text().splitlines()
    except OSError:
        locks = []
    for line in locks:  # "1: FLOCK  ADVISORY  WRITE <pid> <major>:<minor>:<inode> 0 EOF"
        fields = line.split()
        if len(fields) > 5 and fields[1] == "FLOCK" and fields[5] == file_id:
            return f"PID {fields[4]}"
    return "PID unknown"


def _make_folders(folder: pathlib.Path) -> list:
    """Make folder and its missing parents; the folders made, outermost first."""
    missing = []
    for candidate in (folder, *folder.parents):
        if candidate.exists():
            break
        missing.append(candidate)
    made = []
    for candidate in reversed(missing):
        try:
            candidate.mkdir()
        except FileExistsError:  # another run made it meanwhile
            continue
        made.append(candidate)
    return made


def held_locks() -> list:
    """The lock files this process holds."""
    return list(_held)


def remove_lock_files() -> None:
    """Remove the lock files this process holds (a tool ending at once on a signal, or a process
    exiting with claims it did not release: the kernel releases the locks as it exits)."""
    for lock, held in list(_held.items()):
        if held.pid == os.getpid():
            lock.unlink(missing_ok=True)


atexit.register(remove_lock_files)
