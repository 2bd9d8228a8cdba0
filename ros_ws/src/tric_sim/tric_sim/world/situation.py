"""A situation: the plain data that defines an episode's starting scene (the same fields as
tric_msgs/Situation), validated field by field, and its conversion to and from plain data (the
entries of a situations file, tric_sim.world.situation_files). World frame: x forward from the
robot, z up, origin at the robot's base on the table top. Units: m, rad; quaternions xyzw.

Whether a valid situation can physically be (nothing in the table or the robot) is
tric_sim.world.scene_check's; the paper's data sets are tric_sim.world.situations'.
"""

from dataclasses import MISSING, asdict, dataclass, fields, replace

import numpy as np

from tric_sim.tools.untrusted import quoted
from tric_sim.world.perturbations import Perturbation, target_displacement

#: Object kinds each task accepts.
TASK_OBJECTS = {"grasp": ("sphere", "cylinder"), "open_box": ("box",)}
#: Number of dimensions each shape takes: sphere (radius), cylinder (height, radius), box.
OBJECT_DIMENSIONS = {"sphere": 1, "cylinder": 2, "box": 1}
OBSTACLE_DIMENSIONS = {"box": 3, "sphere": 1, "cylinder": 2}
#: Workspace in which any object or obstacle centre must lie (a sanity bound, m).
WORKSPACE_LOW = np.array([-0.2, -0.8, -0.05])
WORKSPACE_HIGH = np.array([1.2, 0.8, 1.2])

IDENTITY = (0.0, 0.0, 0.0, 1.0)
#: The longest situation name, bytes of UTF-8: a file is named after it, with suffixes such as
#: ".mcap.part" and a temporary file's, within the file systems' 255 (NAME_MAX).
NAME_MAX_BYTES = 128
#: The most characters of a name an error message quotes (with the rest of the message within
#: tric_sim.tools.untrusted.QUOTE_LIMIT characters of input).
NAME_QUOTE = 60


@dataclass(frozen=True)
class Obstacle:
    """A solid primitive the robot must avoid: shape "box" (full extents x, y, z), "sphere" (radius)
    or "cylinder" (height, radius; axis = local z), at a world pose."""

    shape: str
    dimensions: tuple
    position: tuple
    orientation: tuple = IDENTITY


@dataclass(frozen=True)
class Situation:
    """Everything that defines an episode's starting scene (see tric_msgs/msg/Situation.msg)."""

    name: str
    task: str
    object_kind: str
    object_dimensions: tuple
    object_position: tuple
    object_orientation: tuple = IDENTITY
    obstacles: tuple = ()
    initial_joint_positions: tuple = ()
    seed: int = 0
    #: Perturbations scheduled within the episode (tric_sim.world.perturbations).
    perturbations: tuple = ()

    def validate(self, n_joints: int = 14) -> "Situation":
        """Return self, or raise ValueError naming the first problem. Whether the scene can
        physically be, against a robot, is tric_sim.world.scene_check.check_scene's."""
        check_name(self.name)
        where = f"situation '{quoted(self.name, NAME_QUOTE)}'"
        if not isinstance(self.task, str) or self.task not in TASK_OBJECTS:
            raise ValueError(
                f"{where}: unknown task '{quoted(self.task, 40)}' "
                f"(known: {', '.join(TASK_OBJECTS)})"
            )
        if not isinstance(self.object_kind, str) or self.object_kind not in TASK_OBJECTS[self.task]:
            raise ValueError(
                f"{where}: object kind '{quoted(self.object_kind, 40)}' does not fit task "
                f"'{self.task}' (expected one of {', '.join(TASK_OBJECTS[self.task])})"
            )
        _check_vector(
            self.object_dimensions,
            OBJECT_DIMENSIONS[self.object_kind],
            f"{where}: object_dimensions of a {self.object_kind}",
            positive=True,
        )
        _check_position(self.object_position, f"{where}: object_position")
        _check_quaternion(self.object_orientation, f"{where}: object_orientation")
        for k, obstacle in enumerate(self.obstacles):
            if not isinstance(obstacle.shape, str) or obstacle.shape not in OBSTACLE_DIMENSIONS:
                raise ValueError(
                    f"{where}: obstacle {k} has unknown shape '{quoted(obstacle.shape, 40)}'"
                )
            _check_vector(
                obstacle.dimensions,
                OBSTACLE_DIMENSIONS[obstacle.shape],
                f"{where}: obstacle {k} dimensions",
                positive=True,
            )
            _check_position(obstacle.position, f"{where}: obstacle {k} position")
            _check_quaternion(obstacle.orientation, f"{where}: obstacle {k} orientation")
        if self.initial_joint_positions:
            _check_vector(
                self.initial_joint_positions, n_joints, f"{where}: initial_joint_positions"
            )
        if not (
            isinstance(self.seed, int)
            and not isinstance(self.seed, bool)
            and 0 <= self.seed < 2**32
        ):
            raise ValueError(f"{where}: seed must be an integer in [0, 2^32)")
        for k, perturbation in enumerate(self.perturbations):
            if not isinstance(perturbation, Perturbation):
                raise ValueError(f"{where}: perturbation {k} is not a Perturbation")
            perturbation.validate(self.task, n_joints, f"{where}: perturbation {k}")
        if any(p.kind == "move_target" for p in self.perturbations):
            moved = np.asarray(self.object_position) + target_displacement(self.perturbations)
            _check_position(tuple(moved), f"{where}: the object moved by its perturbations to")
        return self

    def unperturbed(self) -> "Situation":
        """This situation without its perturbations: the scene as a controller knows it (the
        perturbations are the world's doing)."""
        return replace(self, perturbations=())

    def to_dict(self) -> dict:
        data = asdict(self)
        data["obstacles"] = [asdict(o) for o in self.obstacles]
        data["perturbations"] = [p.to_dict() for p in self.perturbations]
        return _plain(data)

    @classmethod
    def from_dict(cls, data: dict) -> "Situation":
        """Build and validate a situation from plain data; unknown or missing keys are refused."""
        if not isinstance(data, dict):
            raise ValueError(f"a situation must be a mapping, got {type(data).__name__}")
        name = quoted(data.get("name", "?"), NAME_QUOTE)
        known = {f.name for f in fields(cls)}
        unknown = set(data) - known
        if unknown:
            raise ValueError(
                f"situation '{name}': unknown field(s) {quoted(sorted(map(str, unknown)), 100)}"
            )
        required = {f.name for f in fields(cls) if f.default is MISSING}
        missing = required - set(data)
        if missing:
            raise ValueError(f"situation '{name}': missing field(s) {sorted(missing)}")
        values = dict(data)
        try:
            values["obstacles"] = tuple(_obstacle_from_dict(o) for o in data.get("obstacles", ()))
            values["perturbations"] = tuple(
                Perturbation.from_dict(p) for p in _entries(data.get("perturbations", ()))
            )
        except (TypeError, ValueError) as error:
            raise ValueError(f"situation '{name}': {quoted(str(error), 120)}") from None
        for key in (
            "object_dimensions",
            "object_position",
            "object_orientation",
            "initial_joint_positions",
        ):
            if key in values:
                values[key] = _numbers(values[key], f"situation '{name}': {key}")
        return cls(**values).validate()


def check_name(name) -> str:
    """name, or ValueError unless it can name a file: a non-empty string of at most NAME_MAX_BYTES
    bytes of UTF-8, without "/", NUL or other control characters (or lone surrogates), not starting
    with "." (nor "." or "..")."""
    if not isinstance(name, str) or not name:
        raise ValueError("a situation needs a non-empty name")
    size = len(name.encode("utf-8", "surrogatepass"))
    problem = ""
    if size > NAME_MAX_BYTES:
        problem = f"is {size} bytes long, over {NAME_MAX_BYTES}"
    elif "/" in name:
        problem = "holds a '/'"
    elif any(ord(c) < 32 or ord(c) == 127 or 0xD800 <= ord(c) < 0xE000 for c in name):
        problem = "holds a control character or a lone surrogate"
    elif name.startswith("."):
        problem = "starts with '.'"
    if problem:
        raise ValueError(
            f"situation name {quoted(repr(name), NAME_QUOTE)} "
            f"{problem}: it names the situation's files"
        )
    return name


def _entries(value) -> list:
    """The entries of a list field of a situation's plain data, or ValueError."""
    if not isinstance(value, (list, tuple)):
        raise ValueError(f"expected a list, got {quoted(value, 80)}")
    return list(value)


def _obstacle_from_dict(data) -> Obstacle:
    known = {f.name for f in fields(Obstacle)}
    if (
        not isinstance(data, dict)
        or set(data) - known
        or not {"shape", "dimensions", "position"} <= set(data)
    ):
        raise ValueError(
            f"bad obstacle entry {quoted(data, 80)} (expected the keys shape, dimensions, "
            "position and optionally orientation)"
        )
    return Obstacle(
        shape=data["shape"],
        dimensions=_numbers(data["dimensions"], "an obstacle's dimensions"),
        position=_numbers(data["position"], "an obstacle's position"),
        orientation=_numbers(data.get("orientation", IDENTITY), "an obstacle's orientation"),
    )


def _numbers(values, what: str) -> tuple:
    """values (a list of numbers) as a tuple of floats; ValueError naming what when they are not
    numbers, or one is too large for a float (a 400-digit integer)."""
    try:
        return tuple(float(v) for v in values)
    except OverflowError:
        raise ValueError(f"{what} holds a number too large for a float") from None
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be numbers, got {quoted(values, 80)}") from None


def _plain(value):
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        return value.item()
    return value


def _check_vector(values, size, what, positive=False):
    try:
        array = np.asarray(values, dtype=float)
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{what} must be {size} number(s), got {quoted(values, 80)}") from None
    if array.shape != (size,):
        raise ValueError(f"{what} must have {size} value(s), got {array.size}")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{what} has non-finite values")
    if positive and np.any(array <= 0):
        raise ValueError(f"{what} must be positive")


def _check_position(values, what):
    _check_vector(values, 3, what)
    if np.any(np.asarray(values) < WORKSPACE_LOW) or np.any(np.asarray(values) > WORKSPACE_HIGH):
        raise ValueError(
            f"{what} {_rounded(values)} is outside the workspace "
            f"{_rounded(WORKSPACE_LOW)} .. {_rounded(WORKSPACE_HIGH)}"
        )


def _rounded(values) -> tuple:
    """values as a tuple of plain floats rounded to 0.1 mm, for messages."""
    return tuple(round(float(v), 4) for v in values)


def _check_quaternion(values, what):
    _check_vector(values, 4, what)
    if abs(np.linalg.norm(values) - 1.0) > 1e-3:
        raise ValueError(f"{what} must be a unit quaternion (x, y, z, w)")
