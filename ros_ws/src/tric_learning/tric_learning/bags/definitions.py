"""Message definitions as rosbag2 records them: type names, the .msg text with its dependencies,
the fields a definition text declares, the type hash; and the check that an rclpy class matches its
definition."""

from __future__ import annotations

import importlib
import json
import os
import re
from pathlib import Path
from typing import Any

from rosidl_adapter.parser import parse_message_string
from rosidl_parser.definition import (
    AbstractNestedType,
    NamespacedType,
)

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


def definition_fields(type_name: str, text: str) -> dict[str, tuple]:
    """ "pkg/Type" -> its fields ((type, name), ...), for a message type and every type its full
    definition text (as message_definition writes it, or rosbag2) includes: what decoding depends
    on, without comments, constants and defaults. ValueError (or what rosidl's parser raises) when
    the text does not parse."""
    package, name = _package_and_name(type_name)
    fields = {}
    for k, section in enumerate(text.split(f"\n{'=' * 80}\n")):
        if k:
            header, _, section = section.partition("\n")
            if not header.startswith("MSG: "):
                raise ValueError(f"a section starts with {header[:40]!r}, not 'MSG: pkg/Type'")
            package, name = _package_and_name(header[len("MSG: ") :].strip())
        spec = parse_message_string(package, name, section)
        fields[f"{package}/{name}"] = tuple((str(f.type), f.name) for f in spec.fields)
    return fields


def _check_generated_class(msg_class: type[Any], checked: set | None = None) -> None:
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
