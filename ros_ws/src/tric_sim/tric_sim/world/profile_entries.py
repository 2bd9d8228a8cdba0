"""Two entries of a robot profile (tric_sim.world.robot_profile), parsed and checked: the grasp
teacher's settings (where it brings the palm, how it closes the fingers) and the workspace (where
the robot's data sets put their objects). Units: m, rad, s."""

import math
from dataclasses import dataclass
from typing import Any


@dataclass(frozen=True)
class GraspTeacherSettings:
    """Where the grasp teacher (tric_sim.teachers.grasp) brings this robot's palm, and how it
    closes the fingers. shoulder: the point (world, m, (3,)) the arm's reach is measured from;
    palm_to_wrist: from the palm centre back to the wrist, m; wrist_distance: the wrist's
    comfortable distance from the shoulder, m; grasp_gap and pregrasp_distance: kind -> the palm
    centre's distance to the surface at the grasp, and from the grasp pose back to the pre-grasp
    pose, m; closing_speed: the fingers' joints close this fast, joint units (rad or m) per s;
    closing_margin: a finger this close to its joint's closed limit counts as closed, joint
    units; cylinder_min_outward (optional, default 0.2): the least component of a cylinder's
    approach direction along the horizontal pointing away from the robot (1 straight away, 0
    across; a cylinder with no such direction is approached with -0.2 at least)."""

    shoulder: tuple
    palm_to_wrist: float
    wrist_distance: float
    grasp_gap: dict
    pregrasp_distance: dict
    closing_speed: float
    closing_margin: float
    cylinder_min_outward: float = 0.2


@dataclass(frozen=True)
class Workspace:
    """Where a robot's data sets put their objects (tric_sim.world.situations), m and rad; the
    defaults are the paper's (Sec. 5.3). sphere_grid: (low (3,), high (3,)) of the sphere grid;
    cylinder: (height, radius) and cylinder_position (3,); box_side, box_x, box_y: ranges (low,
    high) of a box's side and its centre's x and y; box_yaw: a box turns within +-box_yaw."""

    sphere_radius: float = 0.04
    sphere_grid: tuple = ((0.40, -0.25, 0.15), (0.80, 0.25, 0.55))
    cylinder: tuple = (0.30, 0.05)
    cylinder_position: tuple = (0.65, 0.0, 0.25)
    box_side: tuple = (0.10, 0.25)
    box_x: tuple = (0.50, 0.68)
    box_y: tuple = (-0.20, 0.20)
    box_yaw: float = 0.4


def _numbers(key: str, value: Any, count: int | None = None, positive: bool = False) -> tuple:
    """A number (count None) or a list of count numbers, each finite (and > 0 if positive), as
    floats; ValueError naming the key otherwise."""
    values = [value] if count is None else value
    if (
        not isinstance(values, list)
        or (count is not None and len(values) != count)
        or not all(
            isinstance(v, (int, float))
            and not isinstance(v, bool)
            and math.isfinite(v)
            and (v > 0 or not positive)
            for v in values
        )
    ):
        what = "a number" if count is None else f"a list of {count} numbers"
        raise ValueError(f"'{key}' must be {what}{' > 0' if positive else ''}, not {value!r}")
    return tuple(float(v) for v in values)


def grasp_teacher(entry: Any) -> GraspTeacherSettings:
    """The checked `grasp_teacher` entry of a profile."""
    if not isinstance(entry, dict):
        raise ValueError("'grasp_teacher' must be a mapping")
    fields = [field for field in GraspTeacherSettings.__dataclass_fields__]
    optional = {"cylinder_min_outward"}
    if not set(fields) - optional <= set(entry) <= set(fields):
        raise ValueError(f"'grasp_teacher' must give {fields} ({', '.join(optional)} optional)")
    per_kind = {}
    for key in ("grasp_gap", "pregrasp_distance"):
        kinds = entry[key]
        if not isinstance(kinds, dict) or sorted(kinds) != ["cylinder", "sphere"]:
            raise ValueError(f"'grasp_teacher.{key}' must give sphere and cylinder, m")
        per_kind[key] = {
            kind: _numbers(f"grasp_teacher.{key}.{kind}", kinds[kind])[0] for kind in kinds
        }
    return GraspTeacherSettings(
        shoulder=_numbers("grasp_teacher.shoulder", entry["shoulder"], 3),
        palm_to_wrist=_numbers("grasp_teacher.palm_to_wrist", entry["palm_to_wrist"])[0],
        wrist_distance=_numbers("grasp_teacher.wrist_distance", entry["wrist_distance"])[0],
        closing_speed=_numbers(
            "grasp_teacher.closing_speed", entry["closing_speed"], positive=True
        )[0],
        closing_margin=_numbers("grasp_teacher.closing_margin", entry["closing_margin"])[0],
        grasp_gap=per_kind["grasp_gap"],
        pregrasp_distance=per_kind["pregrasp_distance"],
        cylinder_min_outward=_min_outward(entry),
    )


def _min_outward(entry: dict) -> float:
    """The grasp_teacher entry's cylinder_min_outward, in [-1, 1], or the default where it gives
    none; ValueError otherwise."""
    if "cylinder_min_outward" not in entry:
        return GraspTeacherSettings.cylinder_min_outward
    key = "grasp_teacher.cylinder_min_outward"
    value = _numbers(key, entry["cylinder_min_outward"])[0]
    if not -1.0 <= value <= 1.0:
        raise ValueError(f"'{key}' must be in [-1, 1], not {value}")
    return value


def workspace(entry: Any) -> Workspace:
    """The checked `workspace` entry of a profile (the paper's for each value it leaves out)."""
    fields = Workspace.__dataclass_fields__
    if not isinstance(entry, dict) or not set(entry) <= set(fields):
        raise ValueError(f"'workspace' may give {list(fields)}")
    values: dict = {}
    for key, value in entry.items():
        where = f"workspace.{key}"
        if key == "sphere_grid":
            if not isinstance(value, list) or len(value) != 2:
                raise ValueError(f"'{where}' must be [low xyz, high xyz], m")
            low, high = _numbers(where, value[0], 3), _numbers(where, value[1], 3)
            if not all(a < b for a, b in zip(low, high)):
                raise ValueError(f"'{where}': each low must be below its high")
            values[key] = (low, high)
        elif key in ("box_side", "box_x", "box_y", "cylinder", "cylinder_position"):
            count = 3 if key == "cylinder_position" else 2
            values[key] = _numbers(where, value, count, positive=key in ("cylinder", "box_side"))
            if key.startswith("box") and not values[key][0] < values[key][1]:
                raise ValueError(f"'{where}' must be [low, high] with low < high")
        else:
            values[key] = _numbers(where, value, positive=True)[0]
    return Workspace(**values)
