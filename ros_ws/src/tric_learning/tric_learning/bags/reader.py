"""read_bag: the messages of a bag, decoded; a damaged bag refused, or read up to its damage."""

from __future__ import annotations

import logging
import os
import struct
from collections.abc import Iterable, Iterator, Mapping
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
from mcap_ros2.decoder import DecoderFactory

from tric_learning.bags.definitions import _package_and_name, ros_type_name

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
