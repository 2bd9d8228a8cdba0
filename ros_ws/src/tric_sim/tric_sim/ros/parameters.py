"""Node parameters declared with their type and valid range, checked once at startup.

Every node declares its parameters through declare(): the value must have the default's type (an
integer is taken for a float, an integral float for an integer), a float must be finite, and the
value must lie in the parameter's Range or be one of its choices. Anything else is a ValueError
naming the parameter, which tric_sim.ros.graph.run_node turns into one line on stderr and exit
status 2.
"""

import math
from dataclasses import dataclass

from rcl_interfaces.msg import ParameterDescriptor

_TYPE_NAMES = {
    bool: "true or false",
    int: "an integer",
    float: "a number",
    str: "a string",
    list: "a list of strings",
}


@dataclass(frozen=True)
class Range:
    """Numbers from low to high; low_open excludes low itself (e.g. "positive")."""

    low: float = -math.inf
    high: float = math.inf
    low_open: bool = False

    def __contains__(self, value) -> bool:
        above = value > self.low if self.low_open else value >= self.low
        return above and value <= self.high

    def __str__(self) -> str:
        if self.high == math.inf:
            if self.low == 0 and self.low_open:
                return "positive"
            return f"{'above' if self.low_open else 'at least'} {self.low:g}"
        return f"in {'(' if self.low_open else '['}{self.low:g}, {self.high:g}]"


#: A rate, period, timeout or duration: finite and above zero.
POSITIVE = Range(0.0, low_open=True)
#: A count of iterations, steps, ...
AT_LEAST_ONE = Range(1)
NOT_NEGATIVE = Range(0.0)


def declare(node, name: str, default, description: str, valid=None):
    """Declare parameter name on node (default's type, dynamically typed so that 100 sets a float)
    and return its checked value: ValueError unless it has the default's type, is finite (floats)
    and is in valid (a Range, or a tuple of the allowed values)."""
    kind = type(default)
    detail = (
        f" ({valid})"
        if isinstance(valid, Range)
        else (f" (one of {', '.join(map(str, valid))})" if valid else "")
    )
    value = node.declare_parameter(
        name, default, ParameterDescriptor(description=description + detail, dynamic_typing=True)
    ).value
    checked = _typed(value, kind)
    if checked is None:
        raise ValueError(f"parameter {name} must be {_TYPE_NAMES[kind]}, got {value!r}")
    if kind is float and not math.isfinite(checked):
        raise ValueError(f"parameter {name} must be finite, got {value!r}")
    if isinstance(valid, Range) and checked not in valid:
        raise ValueError(f"parameter {name} must be {valid}, got {value!r}")
    if isinstance(valid, tuple) and checked not in valid:
        raise ValueError(
            f"parameter {name} must be one of {', '.join(map(repr, valid))}, got {value!r}"
        )
    return checked


def _typed(value, kind):
    """value as kind, or None if it is not one (bools are never numbers)."""
    if kind is bool or kind is str:
        return value if isinstance(value, kind) else None
    if kind is list:
        items = list(value) if isinstance(value, (list, tuple)) else None
        return items if items is not None and all(isinstance(item, str) for item in items) else None
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return None
    if kind is int:
        return int(value) if math.isfinite(value) and float(value).is_integer() else None
    return float(value)


def declare_robot(node):
    """Declare the node's `robot` parameter (a shipped profile's name or a profile file) and return
    its RobotModel; a profile it refuses is a ValueError naming the parameter and why."""
    from tric_sim.world.robot_model import RobotModel  # Pinocchio: only for the nodes that use it
    from tric_sim.world.robot_profile import DEFAULT_ROBOT

    robot = declare(
        node,
        "robot",
        DEFAULT_ROBOT,
        "the robot: a profile shipped with tric_sim (its name) or a profile file (docs/robots.md)",
    )
    try:
        return RobotModel(robot)
    except ValueError as error:
        raise ValueError(f"parameter 'robot': {error}") from None
