"""The ranges of the integer fields of our messages, for the values that tools put into them from
their arguments (tric-eval --max-steps into the Execute goal's uint32 max_steps): checked with a
line that names the option before a message is built, since the generated message code answers a
value out of range with a SystemError or an AssertionError. ROS-free and light: the tools check
their arguments with it before rclpy is imported."""

#: Each integer field type's (smallest, largest) value.
INTEGER_RANGES = {
    "uint8": (0, 2**8 - 1),
    "uint32": (0, 2**32 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "uint64": (0, 2**64 - 1),
    "int64": (-(2**63), 2**63 - 1),
}


def check_integer(value, field_type: str, what: str) -> int:
    """value if it is an integer that a field of field_type holds, else ValueError naming what and
    the range."""
    low, high = INTEGER_RANGES[field_type]
    if isinstance(value, bool) or not isinstance(value, int) or not low <= value <= high:
        raise ValueError(f"{what} must be an integer in [{low}, {high}], got {str(value)[:40]}")
    return value
