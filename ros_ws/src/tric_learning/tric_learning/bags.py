"""ROS 2 bags as single MCAP files, written and read without rclpy.

The files follow the conventions of rosbag2's MCAP storage plugin (ROS 2 Jazzy), so `ros2 bag info`,
`ros2 bag play` and Foxglove read them, and so does the independent reader `rosbags`:

- MCAP profile "ros2". One schema per message type: encoding "ros2msg", name "pkg/msg/Type", data
  the .msg text followed by the definitions it depends on, concatenated as rosbag2 does it (see
  `message_definition`). One channel per topic: message encoding "cdr", metadata
  "offered_qos_profiles" (rosbag2's YAML) and "topic_type_hash". Messages are CDR, little endian.
- Chunks are zstd-compressed. `BagWriter.flush` closes the current chunk, so a writer killed with
  SIGKILL loses only what it wrote after its last flush.
- A "rosbag2" metadata record (key "serialized_metadata": rosbag2's bag information, version 9) is
  written when the bag opens and again, final, when it closes, as rosbag2's writer does.
- The writer writes "<path>.part" and renames it to "<path>" on close(): a "*.mcap" file is always a
  finished bag. `read_bag(..., tolerant=True)` reads a ".part" left by a killed writer up to its
  last complete chunk.

Times are integer nanoseconds. Writing takes rclpy-generated message objects (e.g.
sensor_msgs.msg.JointState(...)); reading gives mcap_ros2's decoded objects, with the message's
field names as attributes: numbers and arrays of numbers as Python numbers and lists, uint8[]/byte[]
as bytes, nested messages as objects of the same kind (mcap_ros2 reads char as int8, so char values
above 127 come back negative). wstring fields are not supported.
"""

from __future__ import annotations

import functools
import importlib
import json
import logging
import operator
import os
import re
import struct
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import yaml
import zstandard
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import Channel, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.summary import Summary
from mcap.writer import LIBRARY_IDENTIFIER, CompressionType
from mcap.writer import Writer as McapWriter
from mcap_ros2.decoder import DecoderFactory
from rosidl_adapter.parser import parse_message_string
from rosidl_parser.definition import (
    AbstractNestedType,
    AbstractString,
    Array,
    BasicType,
    NamespacedType,
)

BAG_SUFFIX = ".mcap"
#: Suffix of a bag while it is being written ("<name>.mcap.part").
PART_SUFFIX = ".part"
#: Uncompressed bytes after which the writer closes a chunk by itself (flush() closes one at once).
DEFAULT_CHUNK_SIZE = 256 * 1024
ROSBAG2_METADATA_VERSION = 9
ROS_DISTRO = "jazzy"

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_FOOTER_RECORD_SIZE = 1 + 8 + 20  # opcode, record length, summary start, summary offset start, CRC
_CDR_LITTLE_ENDIAN_HEADER = b"\x00\x01\x00\x00"
_QOS_DEPTH = 10
# What reading a damaged MCAP file raises (CRC mismatches are ValueErrors, zstd errors ZstdErrors).
_DAMAGE_ERRORS = (McapError, ValueError, struct.error, zstandard.ZstdError)
# ... and what following a corrupt offset of the summary section raises.
_INDEX_ERRORS = (*_DAMAGE_ERRORS, OSError, OverflowError)
_log = logging.getLogger(__name__)


# --- message definitions -----------------------------------------------------------------------

# rosbag2 (LocalMessageDefinitionSource) finds the types a .msg file uses with this expression.
_FIELD_TYPE = re.compile(r"(?:^|\n)\s*([a-zA-Z0-9_/]+)(?:\[[^\]]*\])?\s+")
_PRIMITIVE_TYPES = frozenset(
    {
        "bool",
        "byte",
        "char",
        "float32",
        "float64",
        "int8",
        "uint8",
        "int16",
        "uint16",
        "int32",
        "uint32",
        "int64",
        "uint64",
        "string",
        "wstring",
    }
)


def ros_type_name(msg_class: type) -> str:
    """ "pkg/msg/Type" of an rclpy-generated message class, e.g. "sensor_msgs/msg/JointState"."""
    parts = getattr(msg_class, "__module__", "").split(".")
    if not hasattr(msg_class, "SLOT_TYPES") or len(parts) < 2 or parts[1] != "msg":
        raise TypeError(
            f"{msg_class!r} is not a ROS 2 message class (such as sensor_msgs.msg.JointState)"
        )
    return f"{parts[0]}/msg/{msg_class.__name__}"


def _package_and_name(type_name: str) -> tuple[str, str]:
    """("pkg", "Type") of "pkg/msg/Type" or "pkg/Type"."""
    parts = type_name.split("/")
    if len(parts) == 2 or (len(parts) == 3 and parts[1] == "msg"):
        return parts[0], parts[-1]
    raise ValueError(
        f"'{type_name}' is not a message type name such as 'sensor_msgs/msg/JointState'"
    )


def _interface_file(type_name: str, extension: str) -> Path:
    """share/<pkg>/msg/<Type><extension> under the first AMENT_PREFIX_PATH prefix that has it."""
    package, name = _package_and_name(type_name)
    prefixes = [p for p in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep) if p]
    for prefix in prefixes:
        candidate = Path(prefix, "share", package, "msg", name + extension)
        if candidate.is_file():
            return candidate
    raise ValueError(
        f"no share/{package}/msg/{name}{extension} under AMENT_PREFIX_PATH "
        f"({os.pathsep.join(prefixes) or 'unset'}): is the package built and its setup sourced?"
    )


def message_definition(type_name: str, text: str | None = None) -> str:
    """The full definition of a message type as rosbag2 stores it in a bag's schema.

    type_name: "pkg/msg/Type" (or "pkg/Type"). The .msg text as installed (or text, for a type that
    is not), then for every type it uses (sorted by name, depth first, each once): a line of 80 "=",
    "MSG: pkg/Type" and its text.
    """
    included: set[str] = set()

    def text_with_dependencies(name: str, text: str | None = None) -> str:
        if text is None:
            text = _interface_file(name, ".msg").read_bytes().decode("utf-8")
        package = _package_and_name(name)[0]
        used = {
            t if "/" in t else f"{package}/{t}"
            for t in _FIELD_TYPE.findall(text)
            if t not in _PRIMITIVE_TYPES
        }
        for dependency in sorted(used):
            if dependency not in included:
                included.add(dependency)
                text += f"\n{'=' * 80}\nMSG: {dependency}\n" + text_with_dependencies(dependency)
        return text

    return text_with_dependencies(type_name, text)


def _check_generated_class(msg_class: type, checked: set | None = None) -> None:
    """ValueError when an rclpy message class, or one nested in it, has other fields than its
    installed .msg file declares (a stale build): its messages would not decode with that
    definition."""
    checked = set() if checked is None else checked
    if msg_class in checked:
        return
    checked.add(msg_class)
    type_name = ros_type_name(msg_class)
    package, name = _package_and_name(type_name)
    msg_file = _interface_file(type_name, ".msg")
    declared = [
        field.name for field in parse_message_string(package, name, msg_file.read_text()).fields
    ]
    generated = list(msg_class.get_fields_and_field_types())
    if declared != generated:
        raise ValueError(
            f"{msg_class.__module__}.{msg_class.__name__} has the fields {generated} but "
            f"{msg_file} declares {declared}: rebuild {package} so that they match"
        )
    for field_type in msg_class.SLOT_TYPES:
        if isinstance(field_type, AbstractNestedType):
            field_type = field_type.value_type
        if isinstance(field_type, NamespacedType):
            module = importlib.import_module(".".join(field_type.namespaces))
            _check_generated_class(getattr(module, field_type.name), checked)


def _type_hash(type_name: str) -> str:
    """The RIHS01 hash of a message type from its installed type description, "" when there is
    none."""
    try:
        description = json.loads(_interface_file(type_name, ".json").read_text())
    except ValueError:
        return ""
    return next(
        (
            h["hash_string"]
            for h in description.get("type_hashes", [])
            if h.get("type_name") == type_name
        ),
        "",
    )


# --- CDR serialization of rclpy messages ------------------------------------------------------

_BASIC_FORMATS = {
    "boolean": "?",
    "octet": "B",
    "uint8": "B",
    "int8": "b",
    "uint16": "H",
    "int16": "h",
    "uint32": "I",
    "int32": "i",
    "uint64": "Q",
    "int64": "q",
    "float": "f",
    "double": "d",
}
_PACKERS = {fmt: struct.Struct("<" + fmt) for fmt in set(_BASIC_FORMATS.values())}


def serialize_cdr(message: Any) -> bytes:
    """The CDR bytes (with the 4-byte little-endian encapsulation header) of an rclpy message, as
    ROS 2 serializes it, up to the padding after the last field."""
    buffer = bytearray()
    _write_message(buffer, message)
    return _CDR_LITTLE_ENDIAN_HEADER + bytes(buffer)


@functools.cache
def _fields(msg_class: type) -> tuple:
    """(field name, rosidl type) of every field of an rclpy message class, in order."""
    return tuple(zip(msg_class.get_fields_and_field_types(), msg_class.SLOT_TYPES))


def _align(buffer: bytearray, size: int) -> None:
    buffer += bytes(-len(buffer) % size)


def _write_message(buffer: bytearray, message: Any) -> None:
    fields = _fields(type(message))
    if not fields:
        # an empty message is sent as one uint8 (structure_needs_at_least_one_member)
        buffer.append(0)
    for name, field_type in fields:
        _write_value(buffer, field_type, getattr(message, name))


def _write_value(buffer: bytearray, field_type: Any, value: Any) -> None:
    if isinstance(field_type, NamespacedType):
        _write_message(buffer, value)
    elif isinstance(field_type, AbstractNestedType):
        if not isinstance(field_type, Array):  # sequences carry their length, fixed arrays do not
            _write_scalar(buffer, "I", len(value))
        item_type = field_type.value_type
        if isinstance(item_type, BasicType):
            _write_basic_array(buffer, item_type.typename, value)
        else:
            for item in value:
                _write_value(buffer, item_type, item)
    elif isinstance(field_type, AbstractString):
        encoded = value.encode("utf-8")
        _write_scalar(buffer, "I", len(encoded) + 1)
        buffer += encoded + b"\0"
    elif isinstance(field_type, BasicType) and field_type.typename in _BASIC_FORMATS:
        _write_scalar(
            buffer,
            _BASIC_FORMATS[field_type.typename],
            # rclpy: byte = bytes([v])
            value[0] if field_type.typename == "octet" else value,
        )
    else:
        raise ValueError(
            f"cannot serialize a field of type {field_type} (wstring is not supported)"
        )


def _write_scalar(buffer: bytearray, fmt: str, value: Any) -> None:
    packer = _PACKERS[fmt]
    _align(buffer, packer.size)
    buffer += packer.pack(value)


def _write_basic_array(buffer: bytearray, typename: str, values: Any) -> None:
    """values: list, tuple, array.array, numpy array or bytes (rclpy: byte[] is a list of bytes)."""
    if typename == "octet":
        buffer += values if isinstance(values, bytes) else b"".join(values)
    elif typename == "uint8":
        buffer += bytes(values)
    elif len(values):
        fmt = _BASIC_FORMATS[typename]
        _align(buffer, _PACKERS[fmt].size)
        buffer += struct.pack(f"<{len(values)}{fmt}", *values)


# --- writing ---------------------------------------------------------------------------------


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
        self._state = "open"
        self._custom_data: dict[str, str] = {}
        for key, value in (custom_data or {}).items():
            self.set_custom_data(key, value)
        self._topics: dict[str, _Topic] = {}
        self._schema_ids: dict[str, int] = {}
        self._start_ns: int | None = None
        self._end_ns: int | None = None
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = open(self.part_path, "wb")
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
        renames it to path, which it returns. Closing again returns path."""
        if self._state == "closed":
            return self.path
        self._check_open()
        self._write_rosbag2_metadata()
        self._mcap.finish()
        self._file.flush()
        os.fsync(self._file.fileno())
        self._file.close()
        os.replace(self.part_path, self.path)
        directory = os.open(self.path.parent, os.O_RDONLY)
        try:
            os.fsync(directory)  # make the rename itself durable
        finally:
            os.close(directory)
        self._state = "closed"
        return self.path

    def discard(self) -> None:
        """Drops the bag being written: closes and deletes the ".part" file."""
        if self._state == "open":
            self._file.close()
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
        duration_ns = (self._end_ns - start_ns) if count else 0
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


# --- reading ---------------------------------------------------------------------------------


class BagMessage(NamedTuple):
    """One message read from a bag."""

    topic: str
    type_name: str  # "pkg/msg/Type"
    stamp_ns: int  # log time, ns
    message: Any  # decoded: the message's fields as attributes


@dataclass(frozen=True)
class TopicInfo:
    """One topic of a bag."""

    name: str
    type_name: str  # "pkg/msg/Type"
    message_count: int
    latched: bool  # offered with transient-local durability


@dataclass(frozen=True)
class BagInfo:
    """What a bag holds."""

    path: Path
    complete: bool  # False: a ".part" or a damaged file, described up to the damage
    topics: dict[str, TopicInfo]
    message_count: int
    start_ns: int  # log time of the earliest message, ns (0 when there is none)
    end_ns: int  # log time of the latest message, ns (0 when there is none)
    custom_data: dict[str, str]  # rosbag2 custom_data (of the last metadata record the file holds)


class _Damage(Exception):
    """A bag's bytes stop making sense: the file is truncated or corrupt."""

    def __init__(self, path: Path, offset: int, size: int, messages_before: int, reason: str):
        super().__init__(
            f"bag {path} is truncated or corrupt at byte {offset} of {size} ({reason}); "
            f"{messages_before} messages before the damage are readable"
        )


class _BagFile:
    """A bag file open for reading whose read(n) never asks for more than the file holds, so that a
    corrupt length field makes a short read instead of a gigantic allocation."""

    def __init__(self, path: Path):
        self._file = path.open("rb")
        self.size = os.fstat(self._file.fileno()).st_size

    def read(self, n: int = -1) -> bytes:
        remaining = max(0, self.size - self._file.tell())
        return self._file.read(remaining if n < 0 else min(n, remaining))

    def seek(self, offset: int, whence: int = os.SEEK_SET) -> int:
        return self._file.seek(offset, whence)

    def tell(self) -> int:
        return self._file.tell()

    def close(self) -> None:
        self._file.close()

    def __enter__(self) -> _BagFile:
        return self

    def __exit__(self, *exception: Any) -> None:
        self.close()


def _open_bag(path: Path) -> _BagFile:
    """The bag file open for reading; ValueError unless it is an existing MCAP file of profile
    ros2."""
    if not path.exists():
        raise ValueError(f"bag {path} does not exist")
    if not path.is_file():
        raise ValueError(f"bag {path} is not a file")
    file = _BagFile(path)
    try:
        if file.read(len(_MCAP_MAGIC)) != _MCAP_MAGIC:
            raise ValueError(
                f"{path} is not an MCAP bag: "
                + ("it is empty" if file.size == 0 else "it does not start with the MCAP magic")
            )
        try:
            header = next(StreamReader(file, skip_magic=True, record_size_limit=file.size).records)
        except (StopIteration, *_DAMAGE_ERRORS):
            header = None  # a damaged start, reported by whoever reads on
        if header is not None and (not isinstance(header, Header) or header.profile != "ros2"):
            raise ValueError(
                f"{path} is an MCAP file but not a ROS 2 bag (profile "
                f"'{getattr(header, 'profile', '?')}', expected 'ros2')"
            )
    except BaseException:
        file.close()
        raise
    file.seek(0)
    return file


def _is_finished(file: _BagFile) -> bool:
    """Whether an MCAP file ends with a footer record and the closing magic, as a finished bag
    does."""
    if file.size < 2 * len(_MCAP_MAGIC) + _FOOTER_RECORD_SIZE:
        return False
    file.seek(file.size - _FOOTER_RECORD_SIZE - len(_MCAP_MAGIC))
    tail = file.read()
    file.seek(0)
    return (
        tail.endswith(_MCAP_MAGIC)
        and tail[0] == Opcode.FOOTER
        and struct.unpack_from("<Q", tail, 1)[0] == _FOOTER_RECORD_SIZE - 9
    )


def _summary(file: _BagFile) -> Summary | None:
    """The MCAP summary section of a finished bag; None when it has none or it does not read."""
    try:
        return SeekingReader(file, record_size_limit=file.size).get_summary()
    except _INDEX_ERRORS:
        return None


def _records(path: Path) -> Iterator[Any]:
    """The MCAP records of a ROS 2 bag in file order (those in chunks unpacked), CRCs checked.

    Raises _Damage where the file stops being readable (a truncated file: at its end).
    """
    with _open_bag(path) as file:
        records = StreamReader(file, validate_crcs=True, record_size_limit=file.size).records
        messages_read = 0
        while True:
            try:
                record = next(records)
            except StopIteration:
                return
            except _DAMAGE_ERRORS as error:
                reason = str(error) or "the file ends in the middle of a record"
                raise _Damage(path, file.tell(), file.size, messages_read, reason) from None
            messages_read += isinstance(record, Message)
            yield record


def _refusal(path: Path) -> ValueError:
    """The error for a bag read strictly that is not finished, with what it still holds."""
    try:
        for _ in _records(path):
            pass
    except _Damage as damage:
        return _strict_error(damage)
    return ValueError(f"bag {path} is not finished: it does not end with an MCAP footer")


def _strict_error(damage: _Damage) -> ValueError:
    return ValueError(f"{damage} (an unfinished recording?); tric-train --tolerant reads those")


def _check_type(path: Path, topic: str, type_name: str, expected: Mapping[str, Any]) -> None:
    if topic in expected:
        want = (
            expected[topic] if isinstance(expected[topic], str) else ros_type_name(expected[topic])
        )
        if _package_and_name(want) != _package_and_name(type_name):
            raise ValueError(f"bag {path}: topic {topic} has type {type_name}, expected {want}")


def read_bag(
    path: str | os.PathLike,
    topics: Iterable[str] | None = None,
    *,
    expected_types: Mapping[str, str | type] | None = None,
    tolerant: bool = False,
) -> Iterator[BagMessage]:
    """The messages of a bag in file order (the order they were written), decoded.

    topics: read only these (default: all). expected_types: topic -> type ("pkg/msg/Type" or message
    class); a topic of another type raises ValueError before any of its messages (before any message
    at all for a finished bag read strictly); topics missing from the bag are not an error.
    tolerant: False refuses (ValueError) a file that is not a finished bag, saying how many messages
    precede the damage; True yields those messages and logs a warning where the damage starts (use
    it for a ".part" left by a killed writer).
    Also ValueError for a missing file, a file that is not a ROS 2 MCAP bag, or undecodable
    messages.
    """
    path = Path(path)
    selected = None if topics is None else frozenset(topics)
    expected = dict(expected_types or {})
    with _open_bag(path) as file:
        finished = _is_finished(file)
        if not finished and not tolerant:
            raise _refusal(path)
        if finished and not tolerant and expected:
            summary = _summary(file)
            for channel in summary.channels.values() if summary else ():
                if channel.schema_id in summary.schemas:
                    _check_type(
                        path, channel.topic, summary.schemas[channel.schema_id].name, expected
                    )
    return _messages(path, selected, expected, tolerant)


def _messages(
    path: Path, selected: frozenset | None, expected: dict, tolerant: bool
) -> Iterator[BagMessage]:
    schemas: dict[int, Schema] = {}
    # id -> (channel, decoder or None when not selected)
    channels: dict[int, tuple[Channel, Any]] = {}
    decoders = DecoderFactory()
    try:
        for record in _records(path):
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel) and record.id not in channels:
                schema = schemas.get(record.schema_id)
                if schema is None:
                    raise ValueError(f"bag {path}: topic {record.topic} has no schema")
                _check_type(path, record.topic, schema.name, expected)
                decoder = None
                if selected is None or record.topic in selected:
                    decoder = _decoder(path, decoders, record, schema)
                channels[record.id] = (record, decoder)
            elif isinstance(record, Message):
                if record.channel_id not in channels:
                    raise ValueError(
                        f"bag {path}: a message refers to channel {record.channel_id}, "
                        "which the file does not define before it"
                    )
                channel, decoder = channels[record.channel_id]
                if decoder is not None:
                    yield BagMessage(
                        channel.topic,
                        schemas[channel.schema_id].name,
                        record.log_time,
                        _decode(path, decoder, channel, record),
                    )
    except _Damage as damage:
        if not tolerant:
            raise _strict_error(damage) from None
        _log.warning("%s; returning those", damage)


def _decoder(path: Path, decoders: DecoderFactory, channel: Channel, schema: Schema):
    try:
        decoder = decoders.decoder_for(channel.message_encoding, schema)
    except Exception as error:  # mcap_ros2 raises what its .msg parser raises
        raise ValueError(
            f"bag {path}: the schema of {schema.name} (topic {channel.topic}) "
            f"does not parse: {error}"
        ) from None
    if decoder is None:
        raise ValueError(
            f"bag {path}: topic {channel.topic} is '{channel.message_encoding}' with a "
            f"'{schema.encoding}' schema; only 'cdr' with 'ros2msg' can be decoded"
        )
    return decoder


def _decode(path: Path, decoder: Any, channel: Channel, record: Message) -> Any:
    try:
        return decoder(record.data)
    except Exception as error:  # CdrReader raises struct.error, IndexError, UnicodeDecodeError, ...
        raise ValueError(
            f"bag {path}: a message on {channel.topic} at {record.log_time} ns does not "
            f"decode: {error!r}"
        ) from None


def _latched(channel: Channel) -> bool:
    """Whether a channel's offered QoS profiles are transient local (rosbag2 v9 names or v8
    numbers)."""
    try:
        profiles = yaml.safe_load(channel.metadata.get("offered_qos_profiles", "")) or []
        return any(p.get("durability") in ("transient_local", 1) for p in profiles)
    except (yaml.YAMLError, AttributeError, TypeError):
        return False


def _custom_data(path: Path, metadata: list[Metadata]) -> dict[str, str]:
    """custom_data of the last rosbag2 metadata record."""
    records = [m for m in metadata if m.name == "rosbag2" and "serialized_metadata" in m.metadata]
    if not records:
        return {}
    try:
        information = yaml.safe_load(records[-1].metadata["serialized_metadata"])
        return {str(k): str(v) for k, v in (information.get("custom_data") or {}).items()}
    except (yaml.YAMLError, AttributeError) as error:
        raise ValueError(
            f"bag {path}: its rosbag2 metadata record does not read: {error}"
        ) from None


def bag_info(path: str | os.PathLike, *, tolerant: bool = False) -> BagInfo:
    """Topics (types, message counts), time range and custom_data of a bag.

    A finished bag is described from its MCAP summary without reading its messages. A file that is
    not a finished bag raises ValueError unless tolerant, which reads it up to the damage
    (complete=False). Also ValueError for a missing file or a file that is not a ROS 2 MCAP bag.
    """
    path = Path(path)
    with _open_bag(path) as file:
        finished = _is_finished(file)
        if not finished and not tolerant:
            raise _refusal(path)
        summary = _summary(file) if finished else None
        if summary is not None and summary.statistics is not None:
            statistics = summary.statistics
            try:
                return _bag_info(
                    path,
                    True,
                    summary.schemas,
                    summary.channels.values(),
                    statistics.channel_message_counts,
                    list(SeekingReader(file, record_size_limit=file.size).iter_metadata()),
                    statistics.message_start_time,
                    statistics.message_end_time,
                )
            except _INDEX_ERRORS:
                pass  # a damaged index or metadata record: read the records instead
    schemas, channels, counts, metadata = {}, {}, {}, []
    start_ns = end_ns = None
    try:
        for record in _records(path):
            if isinstance(record, Schema):
                schemas[record.id] = record
            elif isinstance(record, Channel):
                channels[record.id] = record
            elif isinstance(record, Metadata):
                metadata.append(record)
            elif isinstance(record, Message):
                counts[record.channel_id] = counts.get(record.channel_id, 0) + 1
                start_ns = record.log_time if start_ns is None else min(start_ns, record.log_time)
                end_ns = record.log_time if end_ns is None else max(end_ns, record.log_time)
    except _Damage as damage:
        if not tolerant:
            raise _strict_error(damage) from None
        finished = False
    return _bag_info(
        path, finished, schemas, channels.values(), counts, metadata, start_ns or 0, end_ns or 0
    )


def _bag_info(
    path: Path,
    complete: bool,
    schemas: Mapping[int, Schema],
    channels: Iterable[Channel],
    counts: Mapping[int, int],
    metadata: list[Metadata],
    start_ns: int,
    end_ns: int,
) -> BagInfo:
    topics = {
        c.topic: TopicInfo(
            c.topic,
            schemas[c.schema_id].name if c.schema_id in schemas else "",
            counts.get(c.id, 0),
            _latched(c),
        )
        for c in channels
    }
    return BagInfo(
        path, complete, topics, sum(counts.values()), start_ns, end_ns, _custom_data(path, metadata)
    )
