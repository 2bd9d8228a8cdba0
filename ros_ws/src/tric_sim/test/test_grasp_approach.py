"""Where the grasp teacher approaches an object from (tric_sim.teachers.grasp_approach): spheres
from the robot's side and above, for every shipped robot in its own workspace; a cylinder pointing
at the robot still gets a grasp point; and the Panda's cylinder_min_outward keeps its cylinder
approaches on one side of the cylinder."""

import math
from dataclasses import replace

import numpy as np
import pytest

from tric_sim.teachers.grasp_approach import approach_direction, cylinder_grasp_point
from tric_sim.world import scene
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


def _approach_in_cylinder_frame(profile, angle: float) -> np.ndarray:
    """The teacher's approach direction for the workspace's cylinder turned by angle (rad),
    in the cylinder's own frame."""
    situation = S.cylinder("c", angle, workspace=profile.workspace)
    rotation = scene.se3(situation.object_position, situation.object_orientation).rotation
    centre = np.asarray(situation.object_position)
    height = situation.object_dimensions[0]
    _, n = cylinder_grasp_point(centre, rotation[:, 2], height, profile.grasp_teacher)
    return rotation.T @ n


def test_the_pandas_cylinder_approach_keeps_one_side_of_the_cylinder():
    """With cylinder_min_outward 0 the Panda approaches every cylinder of its range (upright to
    lying along x) within 20 degrees of one direction in the cylinder's frame (15 measured); held
    to 0.2, as the paper's robot is, the direction turns by 60 degrees over the range (asserted:
    more than 45) and jumps back where no direction away from the robot remains
    (docs/decisions/cylinder-approach.md)."""
    panda = load_profile("panda")
    assert panda.grasp_teacher.cylinder_min_outward == 0.0
    assert load_profile().grasp_teacher.cylinder_min_outward == 0.2
    angles = np.radians(np.arange(0.0, 90.1, 2.0))

    def spread(profile) -> float:
        directions = [_approach_in_cylinder_frame(profile, a) for a in angles]
        return max(
            math.degrees(math.acos(np.clip(a @ b, -1.0, 1.0)))
            for a in directions
            for b in directions
        )

    assert spread(panda) < 20.0
    held = replace(panda, grasp_teacher=replace(panda.grasp_teacher, cylinder_min_outward=0.2))
    assert spread(held) > 45.0
