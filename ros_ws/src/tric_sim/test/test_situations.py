"""The data sets and their generators (tric_sim.world.situations): the paper's, and a robot's own
workspace's."""

import math

import numpy as np
import pytest

from tric_sim.world import situations as S
from tric_sim.world.robot_profile import load_profile


def test_data_set_sizes_and_grid():
    assert len(S.sphere_grid()) == 27
    assert len(S.dataset("sphere_test")) == 15
    assert len(S.dataset("cylinder_train")) == 10
    assert len(S.dataset("box_test")) == 25
    positions = np.array([s.object_position for s in S.sphere_grid()])
    assert np.allclose(positions.min(0), S.PAPER.sphere_grid[0]) and np.allclose(
        positions.max(0), S.PAPER.sphere_grid[1]
    )
    assert len({tuple(p) for p in positions}) == 27
    for s in S.dataset("sphere_test"):
        assert np.all(np.asarray(s.object_position) >= S.PAPER.sphere_grid[0])
        assert np.all(np.asarray(s.object_position) <= S.PAPER.sphere_grid[1])


def test_generators_are_reproducible_and_seeded():
    assert S.sphere_test_set(5, seed=9) == S.sphere_test_set(5, seed=9)
    assert S.sphere_test_set(5, seed=9) != S.sphere_test_set(5, seed=10)
    assert S.box_set(4, seed=1) == S.box_set(4, seed=1)


def test_cylinders_turn_about_y_within_a_quarter_turn():
    for s in S.dataset("cylinder_train"):
        x, y, z, w = s.object_orientation
        assert x == 0 and z == 0
        assert 0 <= 2 * math.atan2(y, w) <= math.pi / 2


def test_boxes_are_cubes_on_the_table():
    for s in S.dataset("box_test"):
        side = s.object_dimensions[0]
        assert S.PAPER.box_side[0] <= side <= S.PAPER.box_side[1]
        assert math.isclose(s.object_position[2], side / 2)


def test_shift_moves_objects_by_about_the_standard_deviation():
    base = S.sphere_grid()
    moved = S.shifted(base, 0.04, seed=1)
    offsets = np.array(
        [np.subtract(m.object_position, b.object_position) for m, b in zip(base, moved)]
    )
    assert 0.02 < offsets.std() < 0.06
    assert S.shifted(base, 0.0)[0].object_position == base[0].object_position


def test_obstacle_stands_between_robot_and_object():
    s = S.with_obstacle(S.sphere("s", (0.6, 0.2, 0.3)))
    (obstacle,) = s.obstacles
    assert np.linalg.norm(obstacle.position[:2]) < np.linalg.norm(s.object_position[:2])


def test_an_unknown_data_set_is_refused():
    with pytest.raises(ValueError, match="unknown data set"):
        S.dataset("nonsense")


def test_validation_sets_are_drawn_apart_from_the_training_and_test_sets():
    counts = {"sphere_val": 15, "cylinder_val": 10, "box_val": 25, "obstacle_val": 10}
    for name, count in counts.items():
        chosen = S.dataset(name)
        assert len(chosen) == count and all(s.name.startswith(name) for s in chosen)
        task = name.split("_")[0].replace("obstacle", "sphere")
        others = S.dataset(f"{task}_train") + S.dataset(f"{task}_test")
        placements = {
            (s.object_position, s.object_orientation, s.object_dimensions) for s in others
        }
        assert not placements & {
            (s.object_position, s.object_orientation, s.object_dimensions) for s in chosen
        }
    plates = [s.obstacles[0] for s in S.dataset("obstacle_val")]
    heights = [plate.dimensions[2] for plate in plates]
    assert all(0.10 <= h <= 0.18 for h in heights) and max(heights) - min(heights) > 0.03
    for situation in S.dataset("obstacle_val"):
        centre, radius = np.asarray(situation.object_position), situation.object_dimensions[0]
        plate = np.asarray(situation.obstacles[0].position)
        gap = (
            np.linalg.norm((centre - plate)[:2]) - radius - situation.obstacles[0].dimensions[0] / 2
        )
        assert 0.04 - 1e-9 <= gap <= 0.10 + 1e-9


def test_wide_sets_lie_where_they_say_outside_the_training_ranges():
    for name in ("sphere_train", "sphere_test", "cylinder_train", "box_train", "box_test"):
        assert all(S.outside_training_range(s) == 0.0 for s in S.dataset(name)), name
    spheres = S.dataset("sphere_wide")
    distances = [S.outside_training_range(s) for s in spheres]
    assert all(d > 0 for d in distances)
    # up to WIDE_MARGIN (10 cm) beyond the grid, whose narrowest side is 40 cm
    assert max(distances) <= S.WIDE_MARGIN / 0.40 + 1e-9
    cylinders = S.dataset("cylinder_wide")
    tilts = [2 * math.atan2(s.object_orientation[1], s.object_orientation[3]) for s in cylinders]
    assert all(t < 0 or t > math.pi / 2 for t in tilts)
    assert all(-S.WIDE_TILT <= t <= math.pi / 2 + S.WIDE_TILT for t in tilts)
    boxes = S.dataset("box_wide")
    yaws = [2 * math.atan2(s.object_orientation[2], s.object_orientation[3]) for s in boxes]
    assert (
        max(abs(y) for y in yaws) <= S.WIDE_BOX_YAW and max(abs(y) for y in yaws) > S.PAPER.box_yaw
    )
    xs = [s.object_position[0] for s in boxes]
    assert S.widened(*S.PAPER.box_x)[0] <= min(xs) and max(xs) <= S.widened(*S.PAPER.box_x)[1]
    assert sum(S.outside_training_range(s) > 0 for s in boxes) > len(boxes) / 2


def test_a_robot_s_workspace_makes_its_own_data_sets():
    """The Panda's profile gives its workspace: the same generators and seeds, its objects (sized
    for its gripper) within its grid; the paper's sets are the default workspace's."""
    workspace = load_profile("panda").workspace
    low, high = workspace.sphere_grid
    spheres = S.dataset("sphere_test", workspace)
    assert len(spheres) == 15 and all(s.object_dimensions == (0.03,) for s in spheres)
    for s in spheres:
        assert np.all(np.asarray(s.object_position) >= low)
        assert np.all(np.asarray(s.object_position) <= high)
    cylinders = S.dataset("cylinder_val", workspace)
    assert {(c.object_dimensions, c.object_position) for c in cylinders} == {
        (workspace.cylinder, workspace.cylinder_position)
    }
    assert S.dataset("box_test") == S.dataset("box_test", S.PAPER)
    assert S.find_situation("sphere_test_03", workspace=workspace) == spheres[3]
    assert S.outside_training_range(spheres[0], workspace) == 0.0
