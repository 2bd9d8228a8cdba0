"""A robot whose gripper's fingers slide on prismatic joints (test/data/slider_gripper.urdf, the
right finger a mimic of the left): its profile loads, its SRDF is written, and the batched
kinematics, PyBullet and the viewer place every frame as Pinocchio does."""

import pathlib

import numpy as np
import pytest
import yaml

from tric_sim.physics import metrics
from tric_sim.physics.profile_check import collision_pair_problems, landmark_disagreement
from tric_sim.viz import scene_view
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.srdf import write_srdf

DATA = pathlib.Path(__file__).resolve().parent / "data"


@pytest.fixture(scope="module")
def robot(tmp_path_factory) -> RobotModel:
    """The slider gripper, its profile in a folder of its own with the SRDF written there."""
    data = yaml.safe_load((DATA / "slider_gripper.yaml").read_text())
    folder = tmp_path_factory.mktemp("slider")
    data["urdf"] = str(DATA / data["urdf"])
    path = folder / "slider_gripper.yaml"
    path.write_text(yaml.safe_dump(data))
    assert write_srdf(str(path), samples=2000) > 0
    return RobotModel(path)


def configurations(robot, count=20, seed=0):
    return np.random.default_rng(seed).uniform(robot.lower, robot.upper, (count, robot.n_joints))


def test_the_profile_names_a_gripper_finger_moved_by_a_mimic_joint(robot):
    profile = robot.profile
    assert robot.joint_names == ("arm_a_joint", "arm_b_joint", "arm_c_joint", "left_finger_joint")
    assert [m.name for m in robot.mimic_joints] == ["right_finger_joint"]
    assert profile.fingers[1].joints == () and profile.flexion_joints == ("left_finger_joint",)
    assert {"hand", "left_tip", "right_tip"} <= profile.hand_links
    assert profile.closing_signs == {"left_finger_joint": -1.0}


def test_the_model_knows_which_joints_slide(robot):
    """The left finger's joint is prismatic (m), the arm's revolute (rad); the paper's robot has
    no prismatic joint."""
    assert robot.prismatic.tolist() == [False, False, False, True]
    assert not RobotModel().prismatic.any()


def test_a_gripper_closes_as_its_joint_falls(robot):
    """The fingers close as the left finger's joint falls (its profile's closing -1): closing moves
    it down, to its lower limit at most, and the fingers' flexion grows as they close."""
    finger = [robot.joint_names.index("left_finger_joint")]
    np.testing.assert_allclose(robot.closed(np.array([0.03]), finger, 0.01), [0.02])
    np.testing.assert_allclose(robot.closed(np.array([0.004]), finger, 0.01), [0.0])
    arm = [0]
    np.testing.assert_allclose(robot.closed(np.array([0.5]), arm, 0.1), [0.6])  # no finger: +1
    q = robot.home.copy()
    open_flexion = metrics.finger_flexion(robot, q)
    q[finger] = 0.01
    assert metrics.finger_flexion(robot, q) > open_flexion
    assert metrics.open_flexion(robot, "sphere") < metrics.open_flexion(robot, "box")


def test_batched_kinematics_slide_the_fingers_as_pinocchio_does(robot):
    frames = ("left_tip", "right_tip", "palm_center", "right_middle")
    qs = configurations(robot)
    positions, rotations = robot.batch_frame_placements(qs, frames)
    for q, position, rotation in zip(qs, positions, rotations):
        robot.forward(q)
        for k, frame in enumerate(frames):
            expected = robot.frame_placement(frame)
            np.testing.assert_allclose(position[k], expected.translation, atol=1e-12)
            np.testing.assert_allclose(rotation[k], expected.rotation, atol=1e-12)
    opening = np.array([0.0, 0.5, 1.0, 0.0]), np.array([0.0, 0.5, 1.0, 0.04])
    gaps = []
    for q in opening:
        robot.forward(q)
        tips = [robot.frame_placement(t).translation for t in ("left_tip", "right_tip")]
        gaps.append(np.linalg.norm(tips[0] - tips[1]))
    assert gaps[1] - gaps[0] == pytest.approx(0.08, abs=1e-9)  # each finger slides 4 cm


def test_pybullet_places_the_landmarks_as_pinocchio_does(robot):
    worst = landmark_disagreement(robot, samples=10)
    assert max(max(gaps) for gaps in worst.values()) < 1e-6
    assert collision_pair_problems(robot) == []


def test_the_viewer_slides_the_fingers_as_pinocchio_does(robot):
    view = scene_view.RobotView(robot)
    for q in configurations(robot, 5, seed=1):
        placements = scene_view.frame_placements(view.static, view.transforms(q))
        robot.forward(q)
        for link in ("left_finger", "right_finger", "left_tip", "hand"):
            expected, got = robot.frame_placement(link), placements[link]
            np.testing.assert_allclose(got.translation, expected.translation, atol=1e-9)
            np.testing.assert_allclose(got.rotation, expected.rotation, atol=1e-9)
