"""The PyBullet world: held objects, the hinged lid, velocity-limited servos, pictures, metrics."""

import math

import numpy as np
import pytest

from tric_sim.physics import metrics
from tric_sim.physics.bullet import pb
from tric_sim.physics.simulation import DISTANCE_CUTOFF, PhysicsWorld
from tric_sim.world import scene
from tric_sim.world import situations as S
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture
def world(robot):
    w = PhysicsWorld(robot)
    yield w
    w.close()


def test_rate_must_be_a_multiple_of_the_control_rate(robot):
    with pytest.raises(ValueError, match="integer multiple"):
        PhysicsWorld(robot, physics_rate_hz=250.0)


def test_held_object_falls_when_released(world):
    world.reset(S.sphere("s", (0.6, 0.0, 0.35)))
    for _ in range(50):
        world.step()
    assert np.allclose(world.object_poses()["object"][0], (0.6, 0.0, 0.35), atol=1e-4)
    world.release_object()
    for _ in range(30):
        world.step()
    assert world.object_poses()["object"][0][2] < 0.30


def test_lid_rests_closed_and_opens_when_pushed_up(world):
    situation = S.box("b", 0.2, 0.6, 0.0, 0.3)
    world.reset(situation)
    assert "lid" in world.object_poses()
    for _ in range(50):
        world.step()
    assert abs(world.lid_angle()) < 0.01
    lid = world.bodies["object"]
    hinge = scene.hinge_placement(situation)
    free_edge = hinge.act(np.array([0.2 + scene.LID_OVERHANG, 0.0, 0.0]))
    for _ in range(40):  # push the lip up with 8 N for 0.4 s
        pb.applyExternalForce(
            lid, 0, [0, 0, 8.0], free_edge.tolist(), pb.WORLD_FRAME, physicsClientId=world.client
        )
        world.step()
    assert world.lid_angle() > metrics.LID_OPEN_ANGLE
    position, _ = world.object_poses()["lid"]
    assert np.allclose(position, hinge.translation, atol=1e-3)  # the hinge does not move


def test_lid_edge_pose_is_the_lip_and_turns_with_the_lid(world):
    situation = S.box("b", 0.2, 0.6, 0.0, 0.3)
    world.reset(situation)
    hinge = scene.hinge_placement(situation)
    lip = hinge.act(np.array([0.2 + scene.LID_OVERHANG, 0.0, 0.0]))
    position, orientation = world.object_poses()["lid_edge"]
    assert np.allclose(position, lip, atol=1e-3)
    assert np.allclose(scene.se3(position, orientation).rotation, hinge.rotation, atol=1e-3)
    pb.resetJointState(world.bodies["object"], 0, 0.5, physicsClientId=world.client)
    position, orientation = world.object_poses()["lid_edge"]
    opened = scene.lid_placement(hinge, 0.5)
    assert np.allclose(
        position, opened.act(np.array([0.2 + scene.LID_OVERHANG, 0.0, 0.0])), atol=1e-3
    )
    assert position[2] > lip[2] + 0.1  # lifted: 25 cm from the hinge, turned by 0.5 rad


def servo_run(world, robot):
    """Three joints commanded 1.0, -0.5 and 0.8 rad away from home, 170 control periods: the
    measured joint positions (171, n) and one period's velocity bound (n,), rad."""
    world.reset(S.sphere("s", (0.6, 0.0, 0.35)))
    target = robot.home.copy()
    target[[0, 3, 8]] += [1.0, -0.5, 0.8]
    world.command(target)
    trajectory = [world.joint_state()[0]]
    for _ in range(170):
        world.step()
        trajectory.append(world.joint_state()[0])
    return np.array(trajectory), robot.velocity_limits * world.control_period, target


def test_servos_bring_the_joints_to_their_targets(world, robot):
    trajectory, _, target = servo_run(world, robot)
    assert np.abs(trajectory[-1] - target).max() < 0.01  # docs/design.md 6: 0.01 rad


@pytest.mark.xfail(
    strict=True,
    reason="goal: no measured joint moves faster than its velocity limit; "
    "measured on 2026-12-01: 1.30 times the limit in one period (arm_4_joint) and up to 0.65 "
    "periods of limit-speed motion ahead of the setpoint (arm_1_joint), in the periods after a "
    "joint starts moving, when the servo catches up with its setpoint",
)
def test_measured_joints_keep_within_their_velocity_limits(world, robot):
    """Per period, and in all: after p periods from rest a joint has travelled at most p periods of
    limit-speed motion."""
    trajectory, limit, _ = servo_run(world, robot)
    periods = np.arange(len(trajectory))[:, None]
    assert np.all(np.abs(np.diff(trajectory, axis=0)) <= limit + 1e-9)
    assert np.all(np.abs(trajectory - trajectory[0]) <= limit * periods + 1e-9)


def test_render_shows_the_scene(world):
    world.reset(S.dataset("box_test")[0])
    image = world.render(160, 120)
    assert image.shape == (120, 160, 3) and image.dtype == np.uint8
    assert len(np.unique(image.reshape(-1, 3), axis=0)) > 20  # not a blank frame


def test_box_metrics_follow_the_lid_angle(world, robot):
    world.reset(S.box("b", 0.15, 0.6, 0.0, 0.0))
    result = metrics.evaluate(world, robot)
    assert result.task == "open_box" and not result.success and math.isnan(result.grasp_cost)
    pb.resetJointState(world.bodies["object"], 0, 0.5, physicsClientId=world.client)
    assert metrics.evaluate(world, robot).success


def test_min_distance_tracks_contact_with_the_table(world, robot):
    world.reset(S.sphere("s", (0.4, 0.5, 0.6)))  # out of the arm's way
    assert world.min_distance == DISTANCE_CUTOFF  # nothing near
    q = robot.home.copy()
    q[1] = 1.9  # swing the arm down onto the table
    q[3] = 0.3
    world.command(q)
    for _ in range(200):
        world.step()
    assert world.min_distance < 0.0
    assert metrics.evaluate(world, robot).collided


def test_joint_stops_hold_a_joint_pushed_past_its_limit(robot, world):
    """A joint found past its limit after a physics step is put back on it (PyBullet's own limits
    are soft: a constant 3 N m held a distal joint 0.22 rad past, and contacts pushed up to 1 rad
    past)."""
    world.reset(S.sphere("s", (0.6, 0.0, 0.35)))
    k = robot.joint_names.index("finger_2_distal_joint")
    index = world.actuated[k]
    pb.resetJointState(
        world.robot_id, index, robot.upper[k] + 0.5, 2.0, physicsClientId=world.client
    )
    world.command(np.minimum(world.targets, robot.upper))
    world.step()
    position, velocity = world.joint_state()
    assert position[k] <= robot.upper[k] + 0.01 and velocity[k] <= 1e-9
    assert world.stops.max_overshoot <= 0.01


def test_lid_hinge_stays_at_or_above_its_closed_stop(world):
    situation = S.box("b", 0.2, 0.6, 0.0, 0.3)
    world.reset(situation)
    lid = world.bodies["object"]
    hinge = scene.hinge_placement(situation)
    free_edge = hinge.act(np.array([0.2 + scene.LID_OVERHANG, 0.0, 0.0]))
    lowest = 0.0
    for _ in range(40):  # press the lip down with 200 N for 0.4 s
        pb.applyExternalForce(
            lid, 0, [0, 0, -200.0], free_edge.tolist(), pb.WORLD_FRAME, physicsClientId=world.client
        )
        world.step()
        lowest = min(lowest, world.lid_angle())
    assert lowest >= -0.01
    assert world.stops.max_overshoot <= 0.01


def test_overshoot_is_measured_and_reported_in_the_metrics(robot, world):
    world.reset(S.sphere("s", (0.6, 0.0, 0.35)))
    world.step()
    assert world.stops.max_overshoot == 0.0 and world.stops.max_overshoot_joint == ""
    # a joint moved past its limit between two measurements (as a solver slip would) is reported
    k = robot.joint_names.index("arm_4_joint")
    world.stops.high[k] = world.joint_state()[0][k] - 0.05  # pretend the limit is 0.05 rad below q
    # without the stop, the joint stays there
    world.stops.enforce = lambda box: None
    world.step()
    judged = metrics.evaluate(world, robot)
    assert judged.max_joint_overshoot == pytest.approx(0.05, abs=0.01)
    assert judged.overshoot_joint == "arm_4_joint"
