"""Files carried to a worker that may not share the caller's disk
(tric_control.evaluation.executors): a ShippedFile holds a file's bytes, and local_path() gives the
worker a path to open. ROS-free."""

import dataclasses
import hashlib
import pathlib
import tempfile


@dataclasses.dataclass(frozen=True)
class ShippedFile:
    """A file's bytes, carried to a worker that may not share the caller's disk; local_path()
    writes them once per worker process."""

    name: str
    content: bytes


#: The paths local_path() wrote, by the sha1 of their content.
_shipped_paths: dict[str, pathlib.Path] = {}


def local_path(file):
    """A path to open for file: a path as given, or a ShippedFile's bytes written to a temporary
    folder of this process (once per content)."""
    if not isinstance(file, ShippedFile):
        return file
    digest = hashlib.sha1(file.content).hexdigest()
    if digest not in _shipped_paths:
        folder = pathlib.Path(tempfile.mkdtemp(prefix="tric-shipped-"))
        path = folder / file.name
        path.write_bytes(file.content)
        _shipped_paths[digest] = path
    return _shipped_paths[digest]
