"""BagWriter: ROS 2 bags as single MCAP files, written as rosbag2's MCAP storage plugin writes
them."""

from __future__ import annotations

import errno
import operator
import os
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, cast

import yaml
from mcap.writer import LIBRARY_IDENTIFIER, CompressionType
from mcap.writer import Writer as McapWriter

from tric_learning.bags.cdr import serialize_cdr
from tric_learning.bags.definitions import (
    _check_generated_class,
    _package_and_name,
    _type_hash,
    message_definition,
    ros_type_name,
)
from tric_sim.tools.claims import open_exclusive
from tric_sim.tools.output_files import rename_without_replacing

BAG_SUFFIX = ".mcap"
#: Suffix of a bag while it is being written ("<name>.mcap.part").
PART_SUFFIX = ".part"
#: Uncompressed bytes after which the writer closes a chunk by itself (flush() closes one at once).
DEFAULT_CHUNK_SIZE = 256 * 1024
ROSBAG2_METADATA_VERSION = 9
ROS_DISTRO = "jazzy"
_QOS_DEPTH = 10


def _offered_qos_profiles(latched: bool) -> list[dict]:
    """rosbag2's description (metadata version 9) of one publisher's QoS: reliable, keep last 10,
    volatile or (latched) transient local, deadline/lifespan/lease unspecified (0 = the default)."""
    return [
        {
            "history": "keep_last",
            "depth": _QOS_DEPTH,
            "reliability": "reliable",
            "durability": "transient_local" if latched else "volatile",
            "deadline": {"sec": 0, "nsec": 0},
            "lifespan": {"sec": 0, "nsec": 0},
            "liveliness": "automatic",
            "liveliness_lease_duration": {"sec": 0, "nsec": 0},
            "avoid_ros_namespace_conventions": False,
        }
    ]


class _NoAliasDumper(yaml.SafeDumper):
    """A YAML dumper that writes repeated objects out instead of as anchors and aliases."""

    def ignore_aliases(self, data: Any) -> bool:
        return True


def _to_yaml(data: Any) -> str:
    return yaml.dump(data, Dumper=_NoAliasDumper, sort_keys=False, default_flow_style=False).rstrip(
        "\n"
    )


@dataclass
class _Topic:
    msg_class: type | None  # None: a type not installed here, written as CDR bytes (write_cdr)
    channel_id: int
    metadata: dict  # rosbag2's topic_metadata
    message_count: int = 0


class BagWriter:
    """Writes one bag: "<path>.part" while open, renamed to path (which must end in ".mcap") by
    close().

    Usage: add_topic() for each topic (add_topic_definition() for a type not installed here),
    write() messages (write_cdr() their bytes), flush() after each sample that must survive
    a crash, close() at the end (or discard() to drop the bag). As a context manager it closes on a
    normal exit and discards on an exception. Not thread-safe.
    """

    def __init__(
        self,
        path: str | os.PathLike,
        custom_data: Mapping[str, str] | None = None,
        chunk_size: int = DEFAULT_CHUNK_SIZE,
        overwrite: bool = False,
    ):
        """path: the finished bag's file; custom_data: rosbag2 custom_data (str -> str), also
        settable later with set_custom_data(); chunk_size: uncompressed bytes per chunk at most;
        overwrite: replace a bag at path on close() (else a bag there is refused at once)."""
        self.path = Path(path)
        if self.path.suffix != BAG_SUFFIX:
            raise ValueError(
                f"bag path {self.path} must end in '{BAG_SUFFIX}' "
                "(ros2 bag tells the storage plugin by it)"
            )
        if self.path.exists() and not (overwrite and self.path.is_file()):
            raise FileExistsError(f"bag {self.path} exists already; refusing to overwrite it")
        self.part_path = self.path.with_name(self.path.name + PART_SUFFIX)
        self._overwrite = overwrite
        self._state = "open"
        self._custom_data: dict[str, str] = {}
        for key, value in (custom_data or {}).items():
            self.set_custom_data(key, value)
        self._topics: dict[str, _Topic] = {}
        self._schema_ids: dict[str, int] = {}
        self._start_ns: int | None = None
        self._end_ns: int | None = None
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = open_exclusive(self.part_path, "bag")  # FileExistsError: another writer's
        self._mcap = McapWriter(self._file, chunk_size=chunk_size, compression=CompressionType.ZSTD)
        self._mcap.start(profile="ros2", library=f"tric_learning.bags; {LIBRARY_IDENTIFIER}")
        self._write_rosbag2_metadata()
        self._file.flush()  # even a writer killed now leaves a file that reads as an (empty) bag

    def set_custom_data(self, key: str, value: str) -> None:
        """Sets an entry of the bag's rosbag2 custom_data, stored at close()."""
        self._check_open()
        if not isinstance(key, str) or not isinstance(value, str):
            raise TypeError(f"custom_data maps str to str, got {key!r}: {value!r}")
        self._custom_data[key] = value

    def add_topic(self, topic: str, msg_type: type, latched: bool = False) -> None:
        """Adds a topic (a name starting with "/") of messages of class msg_type (e.g.
        sensor_msgs.msg.JointState). latched: recorded as offered with transient-local durability,
        so `ros2 bag play` republishes it to late subscribers."""
        self._check_new_topic(topic)
        type_name = ros_type_name(msg_type)
        _check_generated_class(msg_type)
        self._add_channel(topic, msg_type, type_name, None, latched, _type_hash(type_name))

    def add_topic_definition(
        self, topic: str, type_name: str, definition: str, latched: bool = False
    ) -> None:
        """Adds a topic of a message type that is not installed here (e.g. tf2_msgs/msg/TFMessage in
        the pip environment): type_name "pkg/msg/Type", definition its .msg text (the types it uses
        must be installed). Its messages are written as CDR bytes with write_cdr()."""
        self._check_new_topic(topic)
        package, name = _package_and_name(type_name)
        self._add_channel(topic, None, f"{package}/msg/{name}", definition, latched, "")

    def _check_new_topic(self, topic: str) -> None:
        self._check_open()
        if not topic.startswith("/"):
            raise ValueError(f"topic '{topic}' must be a full name starting with '/'")
        if topic in self._topics:
            raise ValueError(f"topic {topic} was added already")

    def _add_channel(self, topic, msg_type, type_name, definition, latched, type_hash) -> None:
        if type_name not in self._schema_ids:
            self._schema_ids[type_name] = self._mcap.register_schema(
                type_name, "ros2msg", message_definition(type_name, definition).encode("utf-8")
            )
        qos = _offered_qos_profiles(latched)
        channel_id = self._mcap.register_channel(
            topic,
            "cdr",
            self._schema_ids[type_name],
            metadata={"offered_qos_profiles": _to_yaml(qos), "topic_type_hash": type_hash},
        )
        self._topics[topic] = _Topic(
            msg_type,
            channel_id,
            {
                "name": topic,
                "type": type_name,
                "serialization_format": "cdr",
                "offered_qos_profiles": qos,
                "type_description_hash": type_hash,
            },
        )

    def write(self, topic: str, message: Any, stamp_ns: int) -> None:
        """Writes message (an object of the topic's class) with log/publish time stamp_ns (ns, >=
        0)."""
        self._check_open()
        if topic not in self._topics:
            raise ValueError(
                f"topic {topic} was not added to {self.part_path} "
                f"(added: {', '.join(self._topics) or 'none'})"
            )
        entry = self._topics[topic]
        if entry.msg_class is None or not isinstance(message, entry.msg_class):
            raise TypeError(
                f"topic {topic} takes {entry.metadata['type']}"
                + (" as CDR bytes (write_cdr)" if entry.msg_class is None else "")
                + f", got {type(message).__name__}"
            )
        self._write_bytes(entry, serialize_cdr(message), stamp_ns)

    def write_cdr(self, topic: str, data: bytes, stamp_ns: int) -> None:
        """Writes a message of a topic added with add_topic_definition(): its CDR bytes (with the
        encapsulation header, see serialize_cdr) with log/publish time stamp_ns (ns, >= 0)."""
        self._check_open()
        entry = self._topics.get(topic)
        if entry is None or entry.msg_class is not None:
            raise ValueError(
                f"topic {topic} was not added with add_topic_definition() to {self.part_path}"
            )
        self._write_bytes(entry, bytes(data), stamp_ns)

    def _write_bytes(self, entry: _Topic, data: bytes, stamp_ns: int) -> None:
        stamp_ns = operator.index(stamp_ns)
        if not 0 <= stamp_ns < 2**64:
            raise ValueError(f"stamp_ns must be a time in ns in [0, 2^64), got {stamp_ns}")
        self._mcap.add_message(
            entry.channel_id, log_time=stamp_ns, data=data, publish_time=stamp_ns
        )
        entry.message_count += 1
        self._start_ns = stamp_ns if self._start_ns is None else min(self._start_ns, stamp_ns)
        self._end_ns = stamp_ns if self._end_ns is None else max(self._end_ns, stamp_ns)

    def flush(self) -> None:
        """Closes the current chunk and hands everything written so far to the operating system, so
        that it survives this process being killed (not a power loss)."""
        self._check_open()
        self._mcap.flush()

    def close(self) -> Path:
        """Writes the final rosbag2 metadata and the MCAP summary, syncs the file to disk and
        renames it to path, which it returns; without overwrite, a bag that appeared at path
        meanwhile is kept, and this one renamed to the first free <stem>_<k>.mcap (path is then
        that). Closing again returns path."""
        if self._state == "closed":
            return self.path
        self._check_open()
        self._write_rosbag2_metadata()
        self._mcap.finish()
        self._file.flush()
        os.fsync(self._file.fileno())
        if self._overwrite:  # renamed while its lock is held: no other writer has the .part
            os.replace(self.part_path, self.path)
        else:
            self.path = _rename_to_free_name(self.part_path, self.path)
        self._file.close()
        directory = os.open(self.path.parent, os.O_RDONLY)
        try:
            os.fsync(directory)  # make the rename itself durable
        finally:
            os.close(directory)
        self._state = "closed"
        return self.path

    def abandon(self) -> Path:
        """Leaves the bag being written unfinished: flushes and closes the ".part" file, which
        keeps everything written so far (readable with tolerant reading); returns its path."""
        if self._state == "open":
            try:
                self._file.flush()
                self._file.close()
            except OSError:  # what was buffered cannot be written (a full disk)
                pass
            self._state = "abandoned"
        return self.part_path

    def discard(self) -> None:
        """Drops the bag being written: closes and deletes the ".part" file."""
        if self._state == "open":
            try:
                self._file.close()
            except OSError:  # what was buffered cannot be written (a full disk): dropped anyway
                pass
            self.part_path.unlink(missing_ok=True)
            self._state = "discarded"

    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, exc_type: Any, exc: Any, traceback: Any) -> None:
        if exc_type is None:
            self.close()
        else:
            self.discard()

    def _check_open(self) -> None:
        if self._state != "open":
            raise ValueError(f"bag writer for {self.path} is {self._state}")

    def _write_rosbag2_metadata(self) -> None:
        """Writes rosbag2's bag information (the metadata.yaml content, version 9) for the bag so
        far."""
        count = sum(t.message_count for t in self._topics.values())
        start_ns = self._start_ns or 0
        # a message written has set _end_ns
        duration_ns = (cast(int, self._end_ns) - start_ns) if count else 0
        information = {
            "version": ROSBAG2_METADATA_VERSION,
            "storage_identifier": "mcap",
            "duration": {"nanoseconds": duration_ns},
            "starting_time": {"nanoseconds_since_epoch": start_ns},
            "message_count": count,
            "topics_with_message_count": [
                {"topic_metadata": t.metadata, "message_count": t.message_count}
                for t in self._topics.values()
            ],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [self.path.name],
            "files": [
                {
                    "path": self.path.name,
                    "starting_time": {"nanoseconds_since_epoch": start_ns},
                    "duration": {"nanoseconds": duration_ns},
                    "message_count": count,
                }
            ],
            "custom_data": dict(self._custom_data),
            "ros_distro": ROS_DISTRO,
        }
        self._mcap.add_metadata("rosbag2", {"serialized_metadata": _to_yaml(information)})


def _rename_to_free_name(source: Path, path: Path) -> Path:
    """Rename source to path, or if a file is there to the first free <stem>_<k><suffix>, without
    ever replacing a file; the name it took."""
    for k in range(10_000):
        target = path if k == 0 else path.with_name(f"{path.stem}_{k}{path.suffix}")
        try:
            rename_without_replacing(source, target)
        except FileExistsError:
            continue
        return target
    raise FileExistsError(errno.EEXIST, f"no free name for the bag {path}")
