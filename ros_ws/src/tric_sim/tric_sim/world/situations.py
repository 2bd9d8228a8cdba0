"""The paper's situations: generators that build its training and test sets (Sec. 5.3)
reproducibly from a seed, our validation sets, and the named data sets (DATASETS, dataset(),
find_situation()). A situation itself is tric_sim.world.situation's; its files
tric_sim.world.situation_files'. World frame: x forward from the robot, z up, origin at the robot's
base on the table top. Units: m, rad; quaternions xyzw.
"""

import math
from dataclasses import replace

import numpy as np

from tric_sim.tools.untrusted import quoted
from tric_sim.world.profile_entries import Workspace
from tric_sim.world.situation import Obstacle, Situation
from tric_sim.world.situation_files import load_situations

#: The paper's workspace (Sec. 5.3): the sphere grid's 3 x 3 x 3 positions over 40 (x) x 50 (y) x
#: 40 cm (z) in front of the robot, 4 cm spheres, the 30 cm x 5 cm cylinder; boxes of side 10 to 25
#: cm on the table, their centres within ranges of x and y, turned about z within +-0.4 rad. A
#: robot profile may give its own (its `workspace` entry).
PAPER = Workspace()


def sphere(name, position, seed=0, radius=PAPER.sphere_radius) -> Situation:
    return Situation(
        name=name,
        task="grasp",
        object_kind="sphere",
        object_dimensions=(radius,),
        object_position=tuple(float(v) for v in position),
        seed=seed,
    ).validate()


def sphere_grid(workspace: Workspace = PAPER) -> list:
    """The 27 training situations: spheres on a 3 x 3 x 3 grid over the workspace's sphere grid."""
    low, high = workspace.sphere_grid
    axes = [np.linspace(low[k], high[k], 3) for k in range(3)]
    positions = [(x, y, z) for x in axes[0] for y in axes[1] for z in axes[2]]
    return [
        sphere(f"sphere_grid_{i:02d}", p, radius=workspace.sphere_radius)
        for i, p in enumerate(positions)
    ]


def sphere_test_set(count: int = 15, seed: int = 1, workspace: Workspace = PAPER) -> list:
    """Spheres at uniformly random positions inside the grid (the paper's 15 test situations)."""
    rng = np.random.default_rng(seed)
    low, high = (np.array(corner) for corner in workspace.sphere_grid)
    return [
        sphere(f"sphere_test_{i:02d}", rng.uniform(low, high), seed, workspace.sphere_radius)
        for i in range(count)
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


def cylinder(name, angle: float, seed=0, workspace: Workspace = PAPER) -> Situation:
    """The workspace's cylinder (the paper's: 30 cm x 5 cm) at its position, turned about the world
    y axis by angle (rad): 0 stands it upright, pi/2 lays it along x."""
    orientation = (0.0, math.sin(angle / 2), 0.0, math.cos(angle / 2))
    return Situation(
        name=name,
        task="grasp",
        object_kind="cylinder",
        object_dimensions=workspace.cylinder,
        object_position=workspace.cylinder_position,
        object_orientation=orientation,
        seed=seed,
    ).validate()


def cylinder_set(
    count: int = 10,
    seed: int = 3,
    prefix: str = "cylinder_train",
    stratified: bool = False,
    workspace: Workspace = PAPER,
) -> list:
    """Cylinders turned about y by angles drawn uniformly from [0, pi/2] (Sec. 5.3.3); stratified:
    the i-th angle drawn uniformly from the i-th of count equal parts of [0, pi/2] (still random in
    [0, pi/2], but never bunched)."""
    rng = np.random.default_rng(seed)
    parts = np.arange(count) if stratified else np.zeros(count)
    width = math.pi / 2 / (count if stratified else 1)
    return [
        cylinder(f"{prefix}_{i:02d}", float((part + rng.uniform()) * width), seed, workspace)
        for i, part in enumerate(parts)
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
    count: int,
    seed: int,
    prefix: str,
    gap_range=(0.04, 0.10),
    height_range=(0.10, 0.18),
    workspace: Workspace = PAPER,
) -> list:
    """Spheres at random positions inside the grid, each behind a plate (with_obstacle) of random
    gap and height drawn uniformly from the ranges, m."""
    rng = np.random.default_rng(seed)
    low, high = (np.array(corner) for corner in workspace.sphere_grid)
    out = []
    for i in range(count):
        position = rng.uniform(low, high)
        gap, height = float(rng.uniform(*gap_range)), float(rng.uniform(*height_range))
        situation = with_obstacle(
            sphere(f"{prefix}_{i:02d}", position, seed, workspace.sphere_radius),
            gap=gap,
            height=height,
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


def box_set(
    count: int = 10,
    seed: int = 4,
    prefix: str = "box_train",
    x_range=None,
    y_range=None,
    yaw: float | None = None,
    workspace: Workspace = PAPER,
) -> list:
    """Boxes with random side, translation (centre x and y within the ranges, m; the workspace's
    by default) and rotation (within +-yaw, rad; the workspace's by default) (Sec. 5.3.5)."""
    x_range = workspace.box_x if x_range is None else x_range
    y_range = workspace.box_y if y_range is None else y_range
    yaw = workspace.box_yaw if yaw is None else yaw
    rng = np.random.default_rng(seed)
    out = []
    for i in range(count):
        side = float(rng.uniform(*workspace.box_side))
        out.append(
            box(
                f"{prefix}_{i:02d}",
                side,
                float(rng.uniform(*x_range)),
                float(rng.uniform(*y_range)),
                float(rng.uniform(-yaw, yaw)),
                seed,
            )
        )
    return out


#: The wider situations of Exp. 5's second half (test-only): boxes turned within +-WIDE_BOX_YAW with
#: their centre ranges widened by half on each side; spheres up to WIDE_MARGIN outside the grid;
#: cylinders turned up to WIDE_TILT beyond [0, pi/2].
WIDE_BOX_YAW = math.pi / 4
WIDE_MARGIN = 0.10
WIDE_TILT = math.pi / 4


def widened(low: float, high: float) -> tuple:
    """A range widened by half its width on each side."""
    half = (high - low) / 2
    return low - half, high + half


def box_wide_set(count: int = 25, seed: int = 8, workspace: Workspace = PAPER) -> list:
    """Boxes as box_set's but turned within +-WIDE_BOX_YAW, their centres within the widened
    ranges."""
    return box_set(
        count,
        seed,
        "box_wide",
        widened(*workspace.box_x),
        widened(*workspace.box_y),
        WIDE_BOX_YAW,
        workspace,
    )


def sphere_wide_set(count: int = 20, seed: int = 9, workspace: Workspace = PAPER) -> list:
    """Spheres outside the training grid, up to WIDE_MARGIN from it: drawn uniformly in the grid
    grown by WIDE_MARGIN on every side, the draws inside the grid skipped."""
    rng = np.random.default_rng(seed)
    low, high = (np.array(corner) for corner in workspace.sphere_grid)
    out: list[Situation] = []
    while len(out) < count:
        position = rng.uniform(low - WIDE_MARGIN, high + WIDE_MARGIN)
        if np.all(position >= low) and np.all(position <= high):
            continue
        out.append(sphere(f"sphere_wide_{len(out):02d}", position, seed, workspace.sphere_radius))
    return out


def cylinder_wide_set(count: int = 10, seed: int = 10, workspace: Workspace = PAPER) -> list:
    """Cylinders turned outside [0, pi/2], by up to WIDE_TILT: half before 0, half past pi/2."""
    rng = np.random.default_rng(seed)
    beyond = rng.uniform(0.0, WIDE_TILT, count)
    angles = [-b if i % 2 == 0 else math.pi / 2 + b for i, b in enumerate(beyond)]
    return [
        cylinder(f"cylinder_wide_{i:02d}", float(a), seed, workspace) for i, a in enumerate(angles)
    ]


def outside_training_range(situation: Situation, workspace: Workspace = PAPER) -> float:
    """How far a situation lies outside its task's training range, as a share of that range's
    width (the largest over its varied dimensions; 0 inside): spheres by position against the
    grid, cylinders by tilt against [0, pi/2], boxes by centre x, y and yaw against box_set's."""

    def beyond(value, low, high):
        return float(max(low - value, value - high, 0.0) / (high - low))

    if situation.object_kind == "sphere":
        low, high = workspace.sphere_grid
        return max(beyond(v, lo, hi) for v, lo, hi in zip(situation.object_position, low, high))
    x, y, z, w = situation.object_orientation
    if situation.object_kind == "cylinder":
        return beyond(2 * math.atan2(y, w), 0.0, math.pi / 2)
    yaw = 2 * math.atan2(z, w)
    return max(
        beyond(situation.object_position[0], *workspace.box_x),
        beyond(situation.object_position[1], *workspace.box_y),
        beyond(yaw, -workspace.box_yaw, workspace.box_yaw),
    )


#: Named data sets: name -> function of a Workspace returning the list of situations. The training
#: sets are the demonstrations; every choice of method or controller is made on them and on the
#: validation sets (*_val, ours, drawn from the same generators with seeds of their own); the test
#: sets (*_test, the paper's) and the wider sets (*_wide, Exp. 5) are only reported.
DATASETS = {
    "sphere_train": sphere_grid,
    "sphere_val": lambda w: [
        replace(s, name=f"sphere_val_{i:02d}")
        for i, s in enumerate(sphere_test_set(15, seed=11, workspace=w))
    ],
    "sphere_test": lambda w: sphere_test_set(15, seed=1, workspace=w),
    "cylinder_train": lambda w: cylinder_set(10, seed=3, prefix="cylinder_train", workspace=w),
    # a second draw of the cylinder training set, and both draws stratified (tric-study's rows)
    "cylinder_b_train": lambda w: cylinder_set(10, seed=15, prefix="cylinder_b_train", workspace=w),
    "cylinder_strat_train": lambda w: cylinder_set(
        10, seed=3, prefix="cylinder_strat_train", stratified=True, workspace=w
    ),
    "cylinder_strat_b_train": lambda w: cylinder_set(
        10, seed=15, prefix="cylinder_strat_b_train", stratified=True, workspace=w
    ),
    "cylinder_val": lambda w: cylinder_set(10, seed=12, prefix="cylinder_val", workspace=w),
    "cylinder_test": lambda w: cylinder_set(10, seed=5, prefix="cylinder_test", workspace=w),
    "obstacle_val": lambda w: obstacle_set(10, seed=14, prefix="obstacle_val", workspace=w),
    "obstacle_test": lambda w: [with_obstacle(s) for s in sphere_test_set(5, seed=6, workspace=w)],
    "box_train": lambda w: box_set(10, seed=4, prefix="box_train", workspace=w),
    "box_val": lambda w: box_set(25, seed=13, prefix="box_val", workspace=w),
    "box_test": lambda w: box_set(25, seed=7, prefix="box_test", workspace=w),
    "box_wide": lambda w: box_wide_set(workspace=w),
    "sphere_wide": lambda w: sphere_wide_set(workspace=w),
    "cylinder_wide": lambda w: cylinder_wide_set(workspace=w),
}


def dataset(name: str, workspace: Workspace = PAPER) -> list:
    """A named data set (see DATASETS) in a workspace (a robot profile's; the paper's by default),
    or ValueError listing the known names."""
    if name not in DATASETS:
        raise ValueError(f"unknown data set '{quoted(name, 80)}' (known: {', '.join(DATASETS)})")
    return DATASETS[name](workspace)


def find_situation(name: str, path=None, workspace: Workspace = PAPER) -> Situation:
    """The situation called name in a situations file (if path is given) or in the named data
    sets of a workspace (the paper's by default)."""
    candidates = (
        load_situations(path)
        if path
        else [s for make in DATASETS.values() for s in make(workspace)]
    )
    for situation in candidates:
        if situation.name == name:
            return situation
    raise ValueError(
        f"no situation named '{quoted(name, 80)}' in {path or 'the built-in data sets'}"
    )
