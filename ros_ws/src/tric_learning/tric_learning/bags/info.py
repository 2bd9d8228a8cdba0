"""bag_info: what a bag holds (topics, message counts, time range, custom data), from its
summary."""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import IO, cast

from mcap.reader import SeekingReader
from mcap.records import Channel, Message, Metadata, Schema

from tric_learning.bags.reader import (
    _INDEX_ERRORS,
    _custom_data,
    _Damage,
    _is_finished,
    _latched,
    _open_bag,
    _records,
    _refusal,
    _strict_error,
    _summary,
)


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
            stream = cast(IO[bytes], file)  # mcap only reads, seeks and tells
            try:
                return _bag_info(
                    path,
                    True,
                    summary.schemas,
                    summary.channels.values(),
                    statistics.channel_message_counts,
                    list(SeekingReader(stream, record_size_limit=file.size).iter_metadata()),
                    statistics.message_start_time,
                    statistics.message_end_time,
                )
            except _INDEX_ERRORS:
                pass  # a damaged index or metadata record: read the records instead
    counts: dict[int, int]
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
