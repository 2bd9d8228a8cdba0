"""The shared kinematic model: joints, limits, mimic coupling, agreement with PyBullet, IK."""

import numpy as np
import pinocchio as pin
import pytest

from tric_sim.physics.simulation import PhysicsWorld, pb
from tric_sim.world import scene, situations
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def test_fourteen_actuated_joints_with_limits(robot):
    assert robot.n_joints == 14
    assert robot.joint_names[:7] == tuple(f"arm_{i}_joint" for i in range(1, 8))
    assert np.all(robot.lower < robot.upper)
    assert np.all(robot.velocity_limits > 0) and np.all(robot.effort_limits > 0)
    robot.check_configuration(robot.home, "home")


def test_landmark_frames_exist(robot):
    profile = robot.profile
    for frame in (profile.palm, *profile.fingertips, *(f.base for f in profile.fingers)):
        assert robot.model.frames[robot.frame_id(frame)].name == frame
    with pytest.raises(ValueError, match="unknown robot frame 'no_such_link'"):
        robot.frame_id("no_such_link")


def test_knuckle_turns_fingers_two_and_three_in_opposition(robot):
    q = robot.home.copy()
    knuckle = robot.joint_names.index("finger_2_knuckle_joint")
    q[knuckle] = 0.4
    robot.forward(q)
    palm = robot.frame_placement("palm_link")
    r2 = palm.rotation.T @ robot.frame_placement("finger_2_knuckle_link").rotation
    r3 = palm.rotation.T @ robot.frame_placement("finger_3_knuckle_link").rotation
    yaw2 = np.arctan2(r2[1, 0], r2[0, 0])
    yaw3 = np.arctan2(r3[1, 0], r3[0, 0])
    assert np.isclose(np.angle(np.exp(1j * (yaw2 - np.pi))), 0.4, atol=1e-9)
    assert np.isclose(np.angle(np.exp(1j * (yaw3 - np.pi))), -0.4, atol=1e-9)


@pytest.mark.parametrize(
    "bad, message",
    [
        (np.zeros(13), "14 joint positions"),
        (np.full(14, np.nan), "non-finite"),
        (np.full(14, 5.0), "outside its limits"),
    ],
)
def test_bad_configurations_are_refused(robot, bad, message):
    with pytest.raises(ValueError, match=message):
        robot.check_configuration(bad)


def test_self_collision_pairs_skip_adjacent_links(robot):
    model, geoms = robot.model, robot.collision_model.geometryObjects
    assert len(robot.collision_model.collisionPairs) > 50
    for pair in robot.collision_model.collisionPairs:
        a, b = geoms[pair.first].parentJoint, geoms[pair.second].parentJoint
        assert a != b and model.parents[a] != b and model.parents[b] != a


def test_pybullet_and_pinocchio_link_poses_agree(robot):
    world = PhysicsWorld(robot)
    try:
        world.reset(situations.sphere("agreement", (0.6, 0.0, 0.35)))
        rng = np.random.default_rng(0)
        worst = 0.0
        for _ in range(25):
            q = rng.uniform(robot.lower, robot.upper)
            for name, angle in robot.urdf_joint_positions(q).items():
                index = (
                    world.actuated[robot.joint_names.index(name)]
                    if name in robot.joint_names
                    else next(m[0] for m in world.mimics)
                )
                pb.resetJointState(world.robot_id, index, angle, physicsClientId=world.client)
            robot.forward(q)
            placements = world.link_placements()
            assert len(placements) == 15
            for name, (position, orientation) in placements.items():
                expected = robot.frame_placement(name)
                got = scene.se3(position, orientation)
                worst = max(
                    worst,
                    np.abs(expected.translation - got.translation).max(),
                    np.linalg.norm(pin.log3(expected.rotation.T @ got.rotation)),
                )
        assert worst < 1e-6
    finally:
        world.close()


def test_reach_places_the_palm(robot):
    robot.forward(robot.home)
    target = robot.frame_placement(robot.profile.palm).copy()
    target.translation = target.translation + np.array([0.05, 0.05, -0.05])
    q = robot.reach(robot.home, robot.profile.palm, target)
    robot.forward(q)
    assert (
        np.linalg.norm(pin.log6(robot.frame_placement(robot.profile.palm).actInv(target)).vector)
        < 1e-4
    )
    robot.check_configuration(q)
