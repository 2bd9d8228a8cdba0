"""The failure classes of the hidden metrics (tric_sim.physics.metrics.grasp_failure, box_failure)
on hand-made states: the robot at home (or with its fingers flexed) and the object put where each
class holds, the cost terms computed from that state; and evaluate() filling them in on the
physics."""

import numpy as np
import pinocchio as pin
import pytest

from tric_sim.physics import metrics
from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.ros import messages
from tric_sim.world import scene, situations
from tric_sim.world.robot_model import RobotModel

RADIUS = 0.04


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def flexed(robot) -> np.ndarray:
    """Home with every finger closed (proximal 0.3, distal 1.2 rad): a flexion of 1.5 rad."""
    q = robot.home.copy()
    for k in (1, 2, 3):
        q[robot.joint_names.index(f"finger_{k}_proximal_joint")] = 0.3
        q[robot.joint_names.index(f"finger_{k}_distal_joint")] = 1.2
    return q


def sphere_from_palm(robot, q, along: float, across: float = 0.0) -> dict:
    """The cost terms of a sphere of RADIUS whose centre is along (m) in front of the palm centre
    (on its normal) and across (m) to its side."""
    robot.forward(q)
    palm = robot.frame_placement(robot.profile.palm)
    centre = palm.translation + along * palm.rotation[:, 2] + across * palm.rotation[:, 1]
    return metrics.grasp_cost_terms(robot, q, "sphere", (RADIUS,), pin.SE3(np.eye(3), centre))


def grasp_class(robot, q, terms, collided=False, lift_tested=True, lift_passed=False) -> str:
    return metrics.grasp_failure(robot, q, "sphere", terms, collided, lift_tested, lift_passed)


def test_flexion_against_the_open_pre_shape(robot):
    assert metrics.finger_flexion(robot, robot.home) == pytest.approx(
        metrics.open_flexion(robot, "sphere")
    )
    assert metrics.finger_flexion(robot, flexed(robot)) == pytest.approx(1.5)
    # wider open for cylinders
    assert metrics.open_flexion(robot, "cylinder") < metrics.open_flexion(robot, "sphere")


def test_a_palm_far_from_the_sphere_with_open_or_closed_fingers(robot):
    far = sphere_from_palm(robot, robot.home, 0.3)
    assert far["palm_distance"] > 0 and far["palm_alignment"] == pytest.approx(0.0, abs=1e-9)
    assert grasp_class(robot, robot.home, far) == "palm off target"
    closed = sphere_from_palm(robot, flexed(robot), 0.3)
    assert grasp_class(robot, flexed(robot), closed) == "fingers closed before the palm arrived"
    assert grasp_class(robot, flexed(robot), closed, collided=True) == "collision"


def test_a_palm_near_the_sphere_but_turned_away(robot):
    # 2 cm to the side of the palm centre
    beside = sphere_from_palm(robot, robot.home, 0.0, RADIUS + 0.02)
    assert beside["palm_distance"] == 0.0 and beside["palm_alignment"] >= metrics.PALM_MISALIGNED
    assert grasp_class(robot, robot.home, beside) == "palm off target"
    assert (
        grasp_class(
            robot, flexed(robot), sphere_from_palm(robot, flexed(robot), 0.0, RADIUS + 0.02)
        )
        == "palm off target"
    )  # near: not "closed before it arrived"


def test_a_palm_in_place_with_the_fingers_open(robot):
    # the sphere 1 cm from the palm centre, 3 cm to its side: the palm near and turned by about 30
    # deg
    in_place = sphere_from_palm(robot, robot.home, RADIUS + 0.01, 0.03)
    assert (
        in_place["palm_distance"] == 0.0
        and 0.0 < in_place["palm_alignment"] < metrics.PALM_MISALIGNED
    )
    assert (
        np.mean(list(in_place.values())) >= metrics.GOOD_GRASP and in_place["finger_contact"] > 0.8
    )
    assert grasp_class(robot, robot.home, in_place) == "fingers short of the surface"


def test_good_grasps_and_the_lift_test_and_fingers_on_one_side(robot):
    good = {
        "finger_contact": 0.1,
        "palm_distance": 0.0,
        "palm_alignment": 0.05,
        "finger_opposition": 0.0,
    }
    assert grasp_class(robot, flexed(robot), good, lift_passed=True) == ""
    assert grasp_class(robot, flexed(robot), good, lift_tested=False) == ""
    assert grasp_class(robot, flexed(robot), good, lift_passed=False) == "slipped in the lift test"
    assert grasp_class(robot, flexed(robot), good, collided=True, lift_passed=True) == "collision"
    one_side = {
        "finger_contact": 0.2,
        "palm_distance": 0.0,
        "palm_alignment": 0.1,
        "finger_opposition": 0.9,
    }
    assert grasp_class(robot, flexed(robot), one_side) == "fingers on one side of the object"


SIDE = 0.2


def box_poses(hinge: pin.SE3) -> dict:
    """The object poses of a closed box of side SIDE whose lid's hinge frame is at hinge (world)."""
    hinge_in_body = pin.SE3(
        pin.utils.rotate("z", np.pi), np.array([SIDE / 2, 0.0, SIDE / 2 + scene.LID_GAP])
    )
    return {
        "object": scene.pose_tuple(hinge * hinge_in_body.inverse()),
        "lid": scene.pose_tuple(hinge),
        "lid_edge": scene.pose_tuple(hinge * scene.lid_edge_offset(SIDE)),
    }


def hinge_putting(point_in_lid: np.ndarray, world_point: np.ndarray) -> pin.SE3:
    """The hinge frame of a box of yaw 0 (lid x along world -x) that puts point_in_lid (lid frame)
    at world_point."""
    rotation = pin.utils.rotate("z", np.pi)
    return pin.SE3(rotation, world_point - rotation @ point_in_lid)


def tips(robot, q) -> np.ndarray:
    robot.forward(q)
    return np.array(
        [robot.frame_placement(tip).translation for tip in robot.profile.lid_fingertips]
    )


def box_class(robot, poses, lid_angle=0.0, collided=False) -> str:
    return metrics.box_failure(robot, robot.home, SIDE, poses, lid_angle, collided)


def test_fingertips_resting_on_the_lid(robot):
    depth, _, thickness = scene.lid_extents(SIDE)
    low = tips(robot, robot.home)
    middle = np.array([low[:, 0].mean(), low[:, 1].mean(), low[:, 2].min()])
    poses = box_poses(hinge_putting(np.array([depth / 2, 0.0, thickness + 0.015]), middle))
    assert box_class(robot, poses) == "stalled above the lid"
    assert box_class(robot, poses, collided=True) == "collision"
    assert box_class(robot, poses, lid_angle=0.5) == ""  # opened: no failure


def test_a_fingertip_under_the_lip(robot):
    depth, _, _ = scene.lid_extents(SIDE)
    tip = tips(robot, robot.home)[0]
    # the lip 2 cm above the fingertip and 1 cm behind it: the tip under the overhang's edge, off
    # the box
    poses = box_poses(
        hinge_putting(np.array([depth - 0.01, 0.0, 0.0]), tip + np.array([0.0, 0.0, 0.02]))
    )
    assert box_class(robot, poses) == "under the lip"
    # the same, 1 cm beneath the lid but over the box body: inside the box, not under the lip
    over_body = box_poses(
        hinge_putting(np.array([SIDE / 2, 0.0, 0.0]), tip + np.array([0.0, 0.0, 0.05]))
    )
    assert box_class(robot, over_body) != "under the lip"


def test_fingertips_away_from_the_lid(robot):
    poses = box_poses(hinge_putting(np.zeros(3), np.array([0.6, -0.4, 0.2])))
    assert box_class(robot, poses) == "away from the lid"


def test_evaluate_fills_in_the_failure_and_the_message_carries_it(robot):
    world = PhysicsWorld(robot)
    try:
        world.reset(situations.dataset("sphere_test")[0])
        # the hand at home, far above the sphere
        grasp = metrics.evaluate(world, robot)
        assert grasp.failure == "palm off target"
        world.reset(situations.dataset("box_test")[0])
        box = metrics.evaluate(world, robot)
        assert box.failure == "away from the lid"
    finally:
        world.close()
    assert messages.metrics_dict(messages.metrics_msg(box))["failure"] == "away from the lid"


def test_metrics_of_bags_recorded_before_the_failure_class_read_as_unknown():
    message = messages.metrics_msg(metrics.TaskMetrics(task="grasp", failure="palm off target"))
    fields = {
        name: getattr(message, name)
        for name in message.get_fields_and_field_types()
        if name != "failure"
    }
    # a message decoded with the old schema
    old = type("TaskMetrics", (), fields)()
    assert messages.metrics_dict(old)["failure"] is None
    assert messages.metrics_dict(message)["failure"] == "palm off target"
