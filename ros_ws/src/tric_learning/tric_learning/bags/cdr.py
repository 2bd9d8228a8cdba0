"""CDR serialization (little endian) of rclpy messages, without rclpy."""

from __future__ import annotations

import functools
import struct
from typing import Any

from rosidl_parser.definition import (
    AbstractNestedType,
    AbstractString,
    Array,
    BasicType,
    NamespacedType,
)

_CDR_LITTLE_ENDIAN_HEADER = b"\x00\x01\x00\x00"


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
def _fields(msg_class: type[Any]) -> tuple:
    """(field name, rosidl type) of every field of an rclpy message class, in order."""
    return tuple(zip(msg_class.get_fields_and_field_types(), msg_class.SLOT_TYPES))


def _align(buffer: bytearray, size: int) -> None:
    buffer += bytes(-len(buffer) % size)


def _write_message(buffer: bytearray, message: Any) -> None:
    # (a class is hashable; mypy does not take type[Any] for Hashable)
    fields = _fields(type(message))  # type: ignore[arg-type]
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
