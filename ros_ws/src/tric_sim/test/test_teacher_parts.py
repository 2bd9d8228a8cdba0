"""The parts every bag is made with: the grasp teacher's palm servo (PoseServo) and the box
teacher's planner (BoxTeacher), each on its own, without the physics."""

import numpy as np
import pinocchio as pin
import pytest

from tric_sim.teachers.box import REACH_STEPS, STEP_DURATION, STEPS, BoxTeacher
from tric_sim.teachers.pose_servo import TABLE_CLEARANCE, PoseServo
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

PERIOD = 0.01


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def palm_pose(robot, q) -> pin.SE3:
    robot.forward(q)
    return robot.data.oMf[robot.frame_id(robot.profile.palm)].copy()


def servo_to(robot, servo, q, target, periods):
    """q after periods of servo steps towards target, and every step taken (periods, 7)."""
    arm = robot.arm_indices
    steps = []
    for _ in range(periods):
        step = servo.step(q, target)
        steps.append(step)
        q = q.copy()
        q[arm] += step
    return q, np.array(steps)


def pose_error(robot, q, target) -> float:
    current = palm_pose(robot, q)
    return float(np.linalg.norm(target.translation - current.translation))


def test_pose_servo_reaches_a_reachable_palm_pose_within_limits(robot):
    """A palm pose the arm reaches (that of another configuration): the servo brings the palm
    within 5 mm, each step within the velocity limits and every joint within its limits."""
    arm = robot.arm_indices
    goal_q = robot.home.copy()
    goal_q[arm] += np.array([0.3, -0.2, 0.2, 0.25, -0.2, 0.2, 0.1])
    target = palm_pose(robot, goal_q)
    servo = PoseServo(robot, PERIOD)
    q, steps = servo_to(robot, servo, robot.home.copy(), target, 400)
    assert pose_error(robot, robot.home, target) > 0.05
    assert pose_error(robot, q, target) < 0.005
    assert np.all(np.abs(steps) <= robot.velocity_limits[arm] * PERIOD + 1e-9)
    assert np.all(q[arm] >= robot.lower[arm]) and np.all(q[arm] <= robot.upper[arm])


def test_pose_servo_keeps_the_hand_above_the_table(robot):
    """A target below the table top: the palm descends but stays near TABLE_CLEARANCE (the
    velocity damper lets it approach, never pass, by more than a few millimetres)."""
    start = palm_pose(robot, robot.home)
    target = pin.SE3(start.rotation, start.translation * np.array([1.0, 1.0, 0.0]) - [0, 0, 0.1])
    servo = PoseServo(robot, PERIOD)
    q, _ = servo_to(robot, servo, robot.home.copy(), target, 400)
    assert palm_pose(robot, q).translation[2] > TABLE_CLEARANCE - 0.005
    assert palm_pose(robot, q).translation[2] < start.translation[2] - 0.05  # it did descend


@pytest.fixture(scope="module")
def box_plan(robot):
    situation = situations.dataset("box_train")[0]
    return situation, BoxTeacher(robot, situation, robot.home.copy(), PERIOD)


def test_box_planner_starts_at_the_start_and_stays_within_limits(robot, box_plan):
    situation, teacher = box_plan
    assert teacher.duration == pytest.approx(STEPS * STEP_DURATION)
    assert np.allclose(teacher.command(0.0), robot.home, atol=1e-6)
    times = np.arange(0.0, teacher.duration + PERIOD, PERIOD)
    commands = np.array([teacher.command(t) for t in times])
    assert np.all(commands >= robot.lower - 1e-12) and np.all(commands <= robot.upper + 1e-12)
    speeds = np.abs(np.diff(commands, axis=0)) / PERIOD
    assert np.all(speeds <= robot.velocity_limits + 1e-6), np.max(speeds / robot.velocity_limits)
    assert teacher.command(teacher.duration + 5.0) == pytest.approx(
        teacher.command(teacher.duration)
    )


def test_box_planner_reaches_under_the_lid_then_lifts_it(robot, box_plan):
    """The plan's fingertip at the end of the reach is near the lid's free edge (within a few cm
    of it) and rises during the lift phase."""
    situation, teacher = box_plan
    tip = robot.frame_id("finger_2_tip")

    def tip_at(t):
        robot.forward(teacher.command(t))
        return robot.data.oMf[tip].translation.copy()

    reached = tip_at(REACH_STEPS * STEP_DURATION)
    lifted = tip_at(teacher.duration)
    box = np.array(situation.object_position)
    assert np.linalg.norm(reached[:2] - box[:2]) < 0.25  # at the box, not elsewhere
    assert lifted[2] > reached[2] + 0.03  # the lift raises the fingertip (and the lid with it)
    assert teacher.phase == "lift_lid"
