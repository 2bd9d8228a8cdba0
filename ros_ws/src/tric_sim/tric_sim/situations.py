"""Situations: the plain data that defines an episode's starting scene, and the paper's data sets.

A situation is saved and loaded as YAML or JSON (the same fields as tric_msgs/Situation). Generators
build the paper's training and test sets (Sec. 5.3) reproducibly from a seed. World frame: x forward
from the robot, z up, origin at the robot's base on the table top. Units: m, rad; quaternions xyzw.
"""

import json
import math
import pathlib
from dataclasses import MISSING, asdict, dataclass, fields, replace

import numpy as np
import yaml

from tric_sim.output_files import write_text_atomic

#: Object kinds each task accepts.
TASK_OBJECTS = {"grasp": ("sphere", "cylinder"), "open_box": ("box",)}
#: Number of dimensions each shape takes: sphere (radius), cylinder (height, radius), box.
OBJECT_DIMENSIONS = {"sphere": 1, "cylinder": 2, "box": 1}
OBSTACLE_DIMENSIONS = {"box": 3, "sphere": 1, "cylinder": 2}

SPHERE_RADIUS = 0.04
CYLINDER_HEIGHT, CYLINDER_RADIUS = 0.30, 0.05
CYLINDER_POSITION = (0.65, 0.0, 0.25)
#: The sphere grid of Sec. 5.3: 3 x 3 x 3 positions over 40 (x) x 50 (y) x 40 (z) cm in front of the
#: robot.
GRID_LOW = np.array([0.40, -0.25, 0.15])
GRID_HIGH = np.array([0.80, 0.25, 0.55])
#: Boxes (Sec. 5.3.5): cube side 10 to 25 cm, placed on the table within these bounds of its
#: centre's x and y, turned about z within +-BOX_YAW.
BOX_SIDE_RANGE = (0.10, 0.25)
BOX_X_RANGE = (0.50, 0.68)
BOX_Y_RANGE = (-0.20, 0.20)
BOX_YAW = 0.4
#: Workspace in which any object or obstacle centre must lie (a sanity bound, m).
WORKSPACE_LOW = np.array([-0.2, -0.8, -0.05])
WORKSPACE_HIGH = np.array([1.2, 0.8, 1.2])
#: How deep the object may reach into the table top, m (a box stands on it, touching it exactly).
TABLE_TOLERANCE = 1e-3

IDENTITY = (0.0, 0.0, 0.0, 1.0)


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

    def validate(self, n_joints: int = 14, robot=None) -> "Situation":
        """Return self, or raise ValueError naming the first problem. With a robot
        (tric_sim.robot_model.RobotModel), the scene is checked against it too (see check_scene)."""
        where = f"situation '{self.name}'"
        if not self.name or not isinstance(self.name, str):
            raise ValueError("a situation needs a non-empty name")
        if not isinstance(self.task, str) or self.task not in TASK_OBJECTS:
            raise ValueError(
                f"{where}: unknown task '{self.task}' (known: {', '.join(TASK_OBJECTS)})"
            )
        if not isinstance(self.object_kind, str) or self.object_kind not in TASK_OBJECTS[self.task]:
            raise ValueError(
                f"{where}: object kind '{self.object_kind}' does not fit task "
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
                raise ValueError(f"{where}: obstacle {k} has unknown shape '{obstacle.shape}'")
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
        if robot is not None:
            check_scene(self, robot)
        return self

    def to_dict(self) -> dict:
        data = asdict(self)
        data["obstacles"] = [asdict(o) for o in self.obstacles]
        return _plain(data)

    @classmethod
    def from_dict(cls, data: dict) -> "Situation":
        """Build and validate a situation from plain data; unknown or missing keys are refused."""
        if not isinstance(data, dict):
            raise ValueError(f"a situation must be a mapping, got {type(data).__name__}")
        known = {f.name for f in fields(cls)}
        unknown = set(data) - known
        if unknown:
            raise ValueError(
                f"situation '{data.get('name', '?')}': unknown field(s) {sorted(unknown)}"
            )
        required = {f.name for f in fields(cls) if f.default is MISSING}
        missing = required - set(data)
        if missing:
            raise ValueError(
                f"situation '{data.get('name', '?')}': missing field(s) {sorted(missing)}"
            )
        values = dict(data)
        try:
            values["obstacles"] = tuple(_obstacle_from_dict(o) for o in data.get("obstacles", ()))
            for key in (
                "object_dimensions",
                "object_position",
                "object_orientation",
                "initial_joint_positions",
            ):
                if key in values:
                    values[key] = tuple(float(v) for v in values[key])
        except (TypeError, ValueError) as error:
            raise ValueError(f"situation '{data.get('name', '?')}': {error}") from None
        return cls(**values).validate()


def check_scene(situation: Situation, robot) -> Situation:
    """situation, or ValueError if it cannot physically be: its object (or the box's lid) reaching
    into the table by more than TABLE_TOLERANCE, or its object, lid or an obstacle intersecting the
    robot (any link, its base too) in its initial configuration (initial_joint_positions, else the
    robot's home). robot: a tric_sim.robot_model.RobotModel."""
    # imported here: tric_sim.scene and tric_sim.shapes import this module
    import coal
    import pinocchio as pin

    from tric_sim.scene import lid_geometry_offset, scene_bodies, se3
    from tric_sim.shapes import coal_shape

    where = f"situation '{situation.name}'"
    q = np.asarray(situation.initial_joint_positions or robot.home, dtype=float)
    data, geometry_data = robot.model.createData(), pin.GeometryData(robot.collision_model)
    pin.updateGeometryPlacements(robot.model, data, robot.collision_model, geometry_data, q)
    robot_parts = [
        (robot.model.frames[g.parentFrame].name, g.geometry, placement)
        for g, placement in zip(robot.collision_model.geometryObjects, geometry_data.oMg)
    ]
    table, *bodies = scene_bodies(situation)
    table_shape, table_placement = (
        coal_shape(table.shape, table.dimensions),
        se3(table.position, table.orientation),
    )

    def distance(shape, placement, other_shape, other_placement) -> float:
        return coal.distance(
            shape,
            coal.Transform3s(placement.rotation, placement.translation),
            other_shape,
            coal.Transform3s(other_placement.rotation, other_placement.translation),
            coal.DistanceRequest(),
            coal.DistanceResult(),
        )

    for body in bodies:
        what = body.name.replace("_", " ") if body.role == "obstacle" else f"the {body.name}"
        shape, placement = (
            coal_shape(body.shape, body.dimensions),
            se3(body.position, body.orientation),
        )
        if body.role == "lid":
            placement = placement * lid_geometry_offset(situation.object_dimensions[0])
        if body.role != "obstacle":
            depth = -distance(shape, placement, table_shape, table_placement)
            if depth > TABLE_TOLERANCE:
                raise ValueError(
                    f"{where}: {what} ({body.shape}) reaches {depth * 100:.1f} cm into the table"
                )
        for link, robot_shape, robot_placement in robot_parts:
            if distance(shape, placement, robot_shape, robot_placement) < 0.0:
                raise ValueError(
                    f"{where}: {what} ({body.shape}) intersects the robot's {link} in its "
                    "initial configuration"
                )
    return situation


def _obstacle_from_dict(data) -> Obstacle:
    known = {f.name for f in fields(Obstacle)}
    if (
        not isinstance(data, dict)
        or set(data) - known
        or not {"shape", "dimensions", "position"} <= set(data)
    ):
        raise ValueError(
            f"bad obstacle entry {data!r} (expected the keys shape, dimensions, position and "
            "optionally orientation)"
        )
    return Obstacle(
        shape=data["shape"],
        dimensions=tuple(float(v) for v in data["dimensions"]),
        position=tuple(float(v) for v in data["position"]),
        orientation=tuple(float(v) for v in data.get("orientation", IDENTITY)),
    )


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
    except (TypeError, ValueError):
        raise ValueError(f"{what} must be {size} number(s), got {values!r}") from None
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
            f"{what} {tuple(values)} is outside the workspace "
            f"{tuple(WORKSPACE_LOW)} .. {tuple(WORKSPACE_HIGH)}"
        )


def _check_quaternion(values, what):
    _check_vector(values, 4, what)
    if abs(np.linalg.norm(values) - 1.0) > 1e-3:
        raise ValueError(f"{what} must be a unit quaternion (x, y, z, w)")


# --- files -------------------------------------------------------------------------------------


def save_situations(path, situations) -> None:
    """Write situations to a .yaml/.yml or .json file as {"situations": [...]}."""
    path = pathlib.Path(path)
    data = {"situations": [s.to_dict() for s in situations]}
    write_text_atomic(
        path,
        json.dumps(data, indent=1) + "\n"
        if path.suffix == ".json"
        else yaml.safe_dump(data, sort_keys=False),
    )


def load_situations(path, robot=None) -> list:
    """Read a situations file (YAML or JSON, a list or {"situations": [...]}); each is validated and
    its scene checked against robot (check_scene; default: a new RobotModel)."""
    path = pathlib.Path(path)
    try:
        text = path.read_text()
    except OSError as error:
        raise ValueError(f"cannot read situations file {path}: {error.strerror}") from None
    try:
        data = json.loads(text) if path.suffix == ".json" else yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError) as error:
        mark = getattr(error, "problem_mark", None)  # YAML's own message spans lines: say it in one
        detail = (
            f"{error.problem} at line {mark.line + 1}, column {mark.column + 1}"
            if mark is not None
            else str(error)
        )
        raise ValueError(
            f"{path} is not valid {'JSON' if path.suffix == '.json' else 'YAML'}: {detail}"
        ) from None
    if isinstance(data, dict):
        data = data.get("situations")
    if not isinstance(data, list) or not data:
        raise ValueError(f"{path} holds no situations (expected a list or {{situations: [...]}})")
    situations = [Situation.from_dict(entry) for entry in data]
    names = [s.name for s in situations]
    if len(set(names)) != len(names):
        raise ValueError(f"{path}: situation names must be unique")
    if robot is None:
        from tric_sim.robot_model import RobotModel  # Pinocchio's model: only when a file is read

        robot = RobotModel()
    for situation in situations:
        check_scene(situation, robot)
    return situations


# --- generators (Sec. 5.3) ---------------------------------------------------------------------


def sphere(name, position, seed=0, radius=SPHERE_RADIUS) -> Situation:
    return Situation(
        name=name,
        task="grasp",
        object_kind="sphere",
        object_dimensions=(radius,),
        object_position=tuple(float(v) for v in position),
        seed=seed,
    ).validate()


def sphere_grid() -> list:
    """The 27 training situations: spheres on a 3 x 3 x 3 grid over GRID_LOW..GRID_HIGH."""
    axes = [np.linspace(GRID_LOW[k], GRID_HIGH[k], 3) for k in range(3)]
    positions = [(x, y, z) for x in axes[0] for y in axes[1] for z in axes[2]]
    return [sphere(f"sphere_grid_{i:02d}", p) for i, p in enumerate(positions)]


def sphere_test_set(count: int = 15, seed: int = 1) -> list:
    """Spheres at uniformly random positions inside the grid (the paper's 15 test situations)."""
    rng = np.random.default_rng(seed)
    return [
        sphere(f"sphere_test_{i:02d}", rng.uniform(GRID_LOW, GRID_HIGH), seed) for i in range(count)
    ]


def shifted(situations, std: float, seed: int = 2, suffix: str = "") -> list:
    """Copies with the object translated by Gaussian noise of standard deviation std (m) per axis
    (the 0 / 2 / 4 cm validation sets of Fig. 9)."""
    rng = np.random.default_rng(seed)
    out = []
    for s in situations:
        position = (
            np.asarray(s.object_position) + rng.normal(0.0, std, 3)
            if std > 0
            else s.object_position
        )
        out.append(
            replace(
                s,
                name=s.name + (suffix or f"_shift{round(std * 100)}cm"),
                object_position=tuple(float(v) for v in position),
                seed=seed,
            ).validate()
        )
    return out


def cylinder(name, angle: float, seed=0) -> Situation:
    """The 30 cm x 5 cm cylinder at CYLINDER_POSITION, turned about the world y axis by angle (rad):
    0 stands it upright, pi/2 lays it along x."""
    orientation = (0.0, math.sin(angle / 2), 0.0, math.cos(angle / 2))
    return Situation(
        name=name,
        task="grasp",
        object_kind="cylinder",
        object_dimensions=(CYLINDER_HEIGHT, CYLINDER_RADIUS),
        object_position=CYLINDER_POSITION,
        object_orientation=orientation,
        seed=seed,
    ).validate()


def cylinder_set(count: int = 10, seed: int = 3, prefix: str = "cylinder_train") -> list:
    """Cylinders turned about y by angles drawn uniformly from [0, pi/2] (Sec. 5.3.3)."""
    rng = np.random.default_rng(seed)
    return [
        cylinder(f"{prefix}_{i:02d}", float(rng.uniform(0.0, math.pi / 2)), seed)
        for i in range(count)
    ]


def with_obstacle(
    situation: Situation,
    thickness: float = 0.03,
    width: float = 0.16,
    height: float = 0.12,
    gap: float = 0.05,
) -> Situation:
    """A copy with a box obstacle across the straight approach: a plate standing gap (m) in front of
    the object's surface, on the line from the robot to the object, its top at the object's
    centre."""
    centre = np.asarray(situation.object_position)
    radius = situation.object_dimensions[-1]
    towards_robot = -centre[:2] / np.linalg.norm(centre[:2])
    xy = centre[:2] + towards_robot * (radius + gap + thickness / 2)
    yaw = math.atan2(towards_robot[1], towards_robot[0])
    obstacle = Obstacle(
        shape="box",
        dimensions=(thickness, width, height),
        position=(float(xy[0]), float(xy[1]), float(centre[2] - height / 2)),
        orientation=(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)),
    )
    return replace(situation, name=situation.name + "_obstacle", obstacles=(obstacle,)).validate()


def obstacle_set(
    count: int, seed: int, prefix: str, gap_range=(0.04, 0.10), height_range=(0.10, 0.18)
) -> list:
    """Spheres at random positions inside the grid, each behind a plate (with_obstacle) of random
    gap and height drawn uniformly from the ranges, m."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        position = rng.uniform(GRID_LOW, GRID_HIGH)
        gap, height = float(rng.uniform(*gap_range)), float(rng.uniform(*height_range))
        situation = with_obstacle(
            sphere(f"{prefix}_{i:02d}", position, seed), gap=gap, height=height
        )
        out.append(replace(situation, name=f"{prefix}_{i:02d}"))
    return out


def box(name, side: float, x: float, y: float, yaw: float, seed=0) -> Situation:
    """A cube of the given side on the table, its lid hinged at the top edge of local +x."""
    return Situation(
        name=name,
        task="open_box",
        object_kind="box",
        object_dimensions=(side,),
        object_position=(x, y, side / 2),
        object_orientation=(0.0, 0.0, math.sin(yaw / 2), math.cos(yaw / 2)),
        seed=seed,
    ).validate()


def box_set(count: int = 10, seed: int = 4, prefix: str = "box_train") -> list:
    """Boxes with random side, translation and rotation (Sec. 5.3.5)."""
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        side = float(rng.uniform(*BOX_SIDE_RANGE))
        out.append(
            box(
                f"{prefix}_{i:02d}",
                side,
                float(rng.uniform(*BOX_X_RANGE)),
                float(rng.uniform(*BOX_Y_RANGE)),
                float(rng.uniform(-BOX_YAW, BOX_YAW)),
                seed,
            )
        )
    return out


#: Named data sets: name -> function returning the list of situations. The training sets are the
#: demonstrations; every choice of method or controller is made on them and on the validation sets
#: (*_val, ours, drawn from the same generators with seeds of their own); the test sets (*_test, the
#: paper's) are only reported.
DATASETS = {
    "sphere_train": sphere_grid,
    "sphere_val": lambda: [
        replace(s, name=f"sphere_val_{i:02d}") for i, s in enumerate(sphere_test_set(15, seed=11))
    ],
    "sphere_test": lambda: sphere_test_set(15, seed=1),
    "cylinder_train": lambda: cylinder_set(10, seed=3, prefix="cylinder_train"),
    "cylinder_val": lambda: cylinder_set(10, seed=12, prefix="cylinder_val"),
    "cylinder_test": lambda: cylinder_set(10, seed=5, prefix="cylinder_test"),
    "obstacle_val": lambda: obstacle_set(10, seed=14, prefix="obstacle_val"),
    "obstacle_test": lambda: [with_obstacle(s) for s in sphere_test_set(5, seed=6)],
    "box_train": lambda: box_set(10, seed=4, prefix="box_train"),
    "box_val": lambda: box_set(25, seed=13, prefix="box_val"),
    "box_test": lambda: box_set(25, seed=7, prefix="box_test"),
}


def dataset(name: str) -> list:
    """A named data set (see DATASETS), or ValueError listing the known names."""
    if name not in DATASETS:
        raise ValueError(f"unknown data set '{name}' (known: {', '.join(DATASETS)})")
    return DATASETS[name]()


def find_situation(name: str, path=None) -> Situation:
    """The situation called name in a situations file (if path is given) or in the named data
    sets."""
    candidates = (
        load_situations(path) if path else [s for make in DATASETS.values() for s in make()]
    )
    for situation in candidates:
        if situation.name == name:
            return situation
    raise ValueError(f"no situation named '{name}' in {path or 'the built-in data sets'}")
