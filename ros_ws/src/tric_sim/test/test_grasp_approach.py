"""Where the grasp teacher approaches an object from (tric_sim.teachers.grasp_approach): spheres
from the robot's side and above, for every shipped robot in its own workspace, and a cylinder
pointing at the robot still gets a grasp point."""

import numpy as np
import pytest

from tric_sim.teachers.grasp_approach import approach_direction, cylinder_grasp_point
from tric_sim.world import situations as S
from tric_sim.world.robot_profile import load_profile


@pytest.mark.parametrize("robot", ["tric_arm_hand", "panda"])
def test_approach_comes_from_the_robots_side_and_above(robot):
    profile = load_profile(robot)
    for situation in S.sphere_grid(profile.workspace):
        n = approach_direction(np.asarray(situation.object_position), profile.grasp_teacher)
        assert n[2] < 0 and n[:2] @ np.asarray(situation.object_position[:2]) > 0


def test_cylinder_pointing_at_the_robot_still_gets_a_grasp_point():
    centre = np.array([0.6, 0.0, 0.3])
    reach = load_profile().grasp_teacher
    # axis along x
    point, direction = cylinder_grasp_point(centre, np.array([1.0, 0.0, 0.0]), 0.3, reach)
    # across the axis, not upwards
    assert abs(direction @ [1.0, 0.0, 0.0]) < 1e-9 and direction[2] <= 0.1
    assert np.linalg.norm(point - centre) <= 0.3 * 0.3 + 1e-9
