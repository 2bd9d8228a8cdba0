"""read_bag: the messages of a bag, decoded; a damaged bag refused, or read up to its damage."""

from __future__ import annotations

import functools
import logging
import os
import struct
from collections.abc import Iterable, Iterator, Mapping
from pathlib import Path
from typing import IO, Any, NamedTuple, cast

import zstandard
from mcap.exceptions import McapError
from mcap.opcode import Opcode
from mcap.reader import SeekingReader
from mcap.records import Channel, Header, Message, Metadata, Schema
from mcap.stream_reader import StreamReader
from mcap.summary import Summary
from mcap_ros2.decoder import DecoderFactory

from tric_learning.bags.definitions import (
    _package_and_name,
    definition_fields,
    message_definition,
    ros_type_name,
)
from tric_sim.tools.untrusted import load_data, quoted

_MCAP_MAGIC = b"\x89MCAP0\r\n"
_FOOTER_RECORD_SIZE = 1 + 8 + 20  # opcode, record length, summary start, summary offset start, CRC
# What reading a damaged MCAP file raises (CRC mismatches are ValueErrors, zstd errors ZstdErrors).
_DAMAGE_ERRORS = (McapError, ValueError, struct.error, zstandard.ZstdError)
# ... and what following a corrupt offset of the summary section raises.
_INDEX_ERRORS = (*_DAMAGE_ERRORS, OSError, OverflowError)
_log = logging.getLogger(__package__)


class BagMessage(NamedTuple):
    """One message read from a bag."""

    topic: str
    type_name: str  # "pkg/msg/Type"
    stamp_ns: int  # log time, ns
    message: Any  # decoded: the message's fields as attributes


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
            stream = cast(IO[bytes], file)  # mcap only reads, seeks and tells
            header = next(
                StreamReader(stream, skip_magic=True, record_size_limit=file.size).records
            )
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
        stream = cast(IO[bytes], file)  # mcap only reads, seeks and tells
        return SeekingReader(stream, record_size_limit=file.size).get_summary()
    except _INDEX_ERRORS:
        return None


def _records(path: Path) -> Iterator[Any]:
    """The MCAP records of a ROS 2 bag in file order (those in chunks unpacked), CRCs checked.

    Raises _Damage where the file stops being readable (a truncated file: at its end).
    """
    with _open_bag(path) as file:
        stream = cast(IO[bytes], file)  # mcap only reads, seeks and tells
        records = StreamReader(stream, validate_crcs=True, record_size_limit=file.size).records
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


def _check_type(
    path: Path,
    topic: str,
    schema: Schema,
    expected: Mapping[str, Any],
    optional: Mapping[str, Iterable[str]],
) -> None:
    """ValueError naming the bag, topic and type unless a topic of expected has the expected type
    name and, field for field, this build's definition of it (the schema's text), but for trailing
    fields that optional ("pkg/Type" -> field names) lets a bag lack."""
    if topic not in expected:
        return
    want = expected[topic] if isinstance(expected[topic], str) else ros_type_name(expected[topic])
    if _package_and_name(want) != _package_and_name(schema.name):
        raise ValueError(f"bag {path}: topic {topic} has type {schema.name}, expected {want}")
    try:
        theirs = definition_fields(schema.name, schema.data.decode("utf-8"))
    except Exception as error:  # rosidl's parser raises its own kinds; UnicodeDecodeError
        problem = f"it does not parse: {quoted(str(error), 120)}"
    else:
        problem = next(
            (
                f"its {name} has the fields {quoted([f[1] for f in theirs.get(name, ())], 60)}, "
                f"this build's {quoted([f[1] for f in fields], 60)}"
                for name, fields in _our_fields(want).items()
                if not _older_version(theirs.get(name), fields, optional.get(name, ()))
            ),
            "",
        )
    if problem:
        raise ValueError(
            f"bag {path}: topic {topic} holds {schema.name} of another definition than this "
            f"build's ({problem}); it was recorded by another version of its package, or is "
            "not a TRIC bag"
        )


def _older_version(theirs: tuple | None, ours: tuple, optional: Iterable[str]) -> bool:
    """Whether a type's fields theirs are ours, or ours less trailing fields that are optional (a
    type the bag's definition lacks (None) is an older version only if all its fields are)."""
    theirs = () if theirs is None else theirs
    return ours[: len(theirs)] == theirs and {name for _, name in ours[len(theirs) :]} <= set(
        optional
    )


@functools.cache
def _our_fields(type_name: str) -> dict[str, tuple]:
    """definition_fields of a type as installed here."""
    return definition_fields(type_name, message_definition(type_name))


def read_bag(
    path: str | os.PathLike,
    topics: Iterable[str] | None = None,
    *,
    expected_types: Mapping[str, str | type] | None = None,
    optional_fields: Mapping[str, Iterable[str]] | None = None,
    tolerant: bool = False,
) -> Iterator[BagMessage]:
    """The messages of a bag in file order (the order they were written), decoded.

    topics: read only these (default: all). expected_types: topic -> type ("pkg/msg/Type" or message
    class); a topic of another type, or of another definition of it (field names and types, the
    types it nests included), raises ValueError before any of its messages (before any message at
    all for a finished bag read strictly); topics missing from the bag are not an error.
    optional_fields: "pkg/Type" -> names of its last fields that a bag's definition may lack (added
    after it was recorded; its reader must do without them).
    tolerant: False refuses (ValueError) a file that is not a finished bag, saying how many messages
    precede the damage; True yields those messages and logs a warning where the damage starts (use
    it for a ".part" left by a killed writer).
    Also ValueError for a missing file, a file that is not a ROS 2 MCAP bag, or undecodable
    messages.
    """
    path = Path(path)
    selected = None if topics is None else frozenset(topics)
    expected, optional = dict(expected_types or {}), dict(optional_fields or {})
    with _open_bag(path) as file:
        finished = _is_finished(file)
        if not finished and not tolerant:
            raise _refusal(path)
        if finished and not tolerant and expected:
            summary = _summary(file)
            if summary:
                for channel in summary.channels.values():
                    if channel.schema_id in summary.schemas:
                        _check_type(
                            path,
                            channel.topic,
                            summary.schemas[channel.schema_id],
                            expected,
                            optional,
                        )
    return _messages(path, selected, expected, optional, tolerant)


def _messages(
    path: Path, selected: frozenset | None, expected: dict, optional: Mapping, tolerant: bool
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
                _check_type(path, record.topic, schema, expected, optional)
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
        profiles = load_data(channel.metadata.get("offered_qos_profiles", ""), "QoS") or []
        return any(p.get("durability") in ("transient_local", 1) for p in profiles)
    except (ValueError, AttributeError, TypeError):
        return False


def _custom_data(path: Path, metadata: list[Metadata]) -> dict[str, str]:
    """custom_data of the last rosbag2 metadata record."""
    records = [m for m in metadata if m.name == "rosbag2" and "serialized_metadata" in m.metadata]
    if not records:
        return {}
    what = f"bag {path}: its rosbag2 metadata record"
    information = load_data(records[-1].metadata["serialized_metadata"], what)
    try:
        return {str(k): str(v) for k, v in (information.get("custom_data") or {}).items()}
    except (AttributeError, TypeError):
        raise ValueError(f"{what} does not hold a custom_data mapping") from None
