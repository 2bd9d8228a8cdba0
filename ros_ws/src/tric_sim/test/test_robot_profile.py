"""Robot profiles: the paper's robot as data, every shipped profile checked against its URDF in
Pinocchio and PyBullet, and each kind of mistake in a profile refused with its name."""

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pytest
import yaml

from tric_sim import robot_check
from tric_sim.physics.profile_check import (
    AGREEMENT,
    collision_pair_problems,
    landmark_disagreement,
    mass_disagreement,
)
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.robot_profile import DEFAULT_ROBOT, PROFILE_DIR, load_profile

SHIPPED = sorted(path.stem for path in PROFILE_DIR.glob("*.yaml"))


def test_the_default_profile_is_the_paper_robot():
    profile = load_profile()
    assert profile.name == DEFAULT_ROBOT == "tric_arm_hand"
    assert len(profile.arm_joints) == 7 and len(profile.hand_joints) == 7
    assert len(profile.fingers) == 3 and profile.fingertips[0] == "finger_1_tip"
    assert profile.flexion_joints == tuple(
        j for j in profile.hand_joints if j != "finger_2_knuckle_joint"
    )
    assert set(profile.lid_fingertips) <= set(profile.fingertips)
    assert {"palm_link", "palm_center", *profile.fingertips} <= profile.hand_links
    assert not {"arm_7_link", "base_link"} & profile.hand_links
    assert load_profile(PROFILE_DIR / "tric_arm_hand.yaml").digest == profile.digest


def test_a_change_of_the_profile_since_a_file_was_made_is_named(tmp_path, profile_data):
    """A bag or model records the profile's identity (name:digest); an edited profile of the same
    robot (here one pre-shape angle) is named with both digests; the same identity, none recorded
    (older files) or another robot's (refused by its feature definition) give no note."""
    profile = load_profile()
    assert profile.identity == f"tric_arm_hand:{profile.digest}" and len(profile.digest) == 64
    profile_data["preshapes"]["sphere"]["finger_1_proximal_joint"] += 0.01
    path = tmp_path / "tric_arm_hand.yaml"
    path.write_text(yaml.safe_dump(profile_data))
    edited = load_profile(path)
    assert edited.name == profile.name and edited.digest != profile.digest
    note = edited.change_since(profile.identity, "model m.safetensors")
    assert note.startswith("model m.safetensors was made with another version of the robot ")
    assert f"'tric_arm_hand' (digest {profile.digest[:12]}, now {edited.digest[:12]})" in note
    for recorded in (edited.identity, "", f"panda:{profile.digest}", "tric_arm_hand"):
        assert edited.change_since(recorded, "bag") == ""


def test_the_hand_geometries_are_the_hand_links():
    robot = RobotModel()
    frames = robot.model.frames
    names = [frames[g.parentFrame].name for g in robot.collision_model.geometryObjects]
    hand = {name for name, on_hand in zip(names, robot.hand_geometries) if on_hand}
    assert "palm_link" in hand and "finger_1_distal_link" in hand
    assert not any(name.startswith("arm_") for name in hand)
    assert all(name in hand for name in names if name.startswith(("finger_", "palm")))


@pytest.mark.parametrize("name", SHIPPED)
def test_every_profile_s_landmarks_agree_in_pinocchio_and_pybullet(name):
    """Over random configurations, each landmark frame of the profile as Pinocchio places it and as
    PyBullet does, to 1e-6 m and rad; and the self-collision pairs consistent (none on one link or
    between neighbours, none the SRDF disables, the SRDF naming links of the URDF)."""
    robot = RobotModel(name)
    worst = landmark_disagreement(robot, samples=10)
    profile = robot.profile
    named = {profile.base, profile.palm, *profile.fingertips, *profile.finger_middles}
    assert named | ({profile.grasp_centre} - {""}) <= set(worst)
    assert max(max(gaps) for gaps in worst.values()) < AGREEMENT
    assert collision_pair_problems(robot) == []
    masses = mass_disagreement(robot)
    assert set(masses) >= set(profile.arm_joints) and max(masses.values()) < AGREEMENT


def test_the_check_finds_a_link_without_an_inertial(tmp_path, profile_data):
    """PyBullet gives a link without an inertial 1 kg, Pinocchio nothing: the check reports the
    body that carries it, and only it (the Panda's derived frames had none: its fingers weighed
    4 kg in the simulator)."""
    urdf = ET.parse(profile_data["urdf"])
    tip = next(link for link in urdf.getroot().iter("link") if link.get("name") == "finger_1_tip")
    tip.remove(tip.find("inertial"))
    profile_data["urdf"] = str(tmp_path / "robot.urdf")
    urdf.write(profile_data["urdf"])
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(profile_data))
    masses = mass_disagreement(RobotModel(load_profile(path)))
    assert masses["finger_1_distal_joint"] == pytest.approx(1.0)
    assert all(gap < AGREEMENT for joint, gap in masses.items() if joint != "finger_1_distal_joint")


def test_the_check_finds_a_landmark_placed_elsewhere(monkeypatch):
    """A fingertip that Pinocchio places 1 mm off PyBullet's is reported, and only it."""
    robot = RobotModel()
    tip, placement = robot.profile.fingertips[0], robot.frame_placement
    moved = pin.SE3(np.eye(3), np.array([0.001, 0.0, 0.0]))
    monkeypatch.setattr(
        robot, "frame_placement", lambda f: placement(f) * moved if f == tip else placement(f)
    )
    worst = landmark_disagreement(robot, samples=3)
    assert worst[tip][0] > 5e-4
    assert all(max(gaps) < AGREEMENT for frame, gaps in worst.items() if frame != tip)


def test_the_check_finds_checked_pairs_the_srdf_disables():
    problems = collision_pair_problems(RobotModel(use_srdf=False))
    assert problems and all("SRDF disables" in problem for problem in problems)


@pytest.fixture
def profile_data() -> dict:
    """The default profile's entries, its URDF and SRDF given as absolute paths."""
    data = yaml.safe_load((PROFILE_DIR / f"{DEFAULT_ROBOT}.yaml").read_text())
    data["urdf"] = str(PROFILE_DIR / data["urdf"])
    data["srdf"] = str(PROFILE_DIR / data["srdf"])
    return data


def _fingertip(data, name):
    data["fingers"][0]["tip"] = name


def _hand_joint(data, name):
    data["hand_joints"][-1] = name


def _arm_joint_left_out(data, _name):
    data["arm_joints"].pop()


def _preshape_joint(data, name):
    data["preshapes"]["sphere"][name] = 0.0


def _closing(data, sign):
    data["fingers"][0]["closing"] = [int(sign), 1]


def _home_angle(data, _name):
    data["home"]["arm_1_joint"] = "zero"


@pytest.mark.parametrize(
    "mistake, name, message",
    [
        (_fingertip, "finger_9_tip", "finger 1 tip: frame 'finger_9_tip' is not a link"),
        (lambda d, n: d.update(palm=n), "palm_centre", "palm: frame 'palm_centre' is not a link"),
        (_hand_joint, "finger_9_distal_joint", "joint 'finger_9_distal_joint' is not a moving"),
        (_arm_joint_left_out, "arm_7_joint", r"left out: \['arm_7_joint'\]"),
        (_preshape_joint, "arm_1_joint", "preshapes.sphere: joint 'arm_1_joint' is not one of"),
        (_home_angle, "arm_1_joint", "home: 'arm_1_joint' must be a finite angle"),
        (lambda d, n: d.pop(n), "grip", r"missing entries \['grip'\]"),
        (lambda d, n: d.update({n: 1}), "gripper", r"unknown entries \['gripper'\]"),
        (lambda d, n: d.update(hand_root=n), "wrist_link", "hand_root: frame 'wrist_link'"),
        (
            lambda d, n: d.update(grasp_centre=n),
            "grasp_point",
            "grasp_centre: frame 'grasp_point' is not a link",
        ),
        (_closing, "2", "finger 1: closing must give \\+1 or -1 for each of its joints"),
        (lambda d, n: d["grasp_teacher"].pop(n), "shoulder", "'grasp_teacher' must give"),
        (
            lambda d, n: d["grasp_teacher"]["grasp_gap"].pop(n),
            "cylinder",
            "'grasp_teacher.grasp_gap' must give sphere and cylinder",
        ),
        (
            lambda d, n: d["grasp_teacher"].update(closing_speed=0.0),
            "closing_speed",
            "'grasp_teacher.closing_speed' must be a number > 0",
        ),
        (
            lambda d, n: d["grasp_teacher"].update({n: 1.5}),
            "cylinder_min_outward",
            r"'grasp_teacher.cylinder_min_outward' must be in \[-1, 1\], not 1.5",
        ),
        (
            lambda d, n: d.update(workspace={n: [[0.4, 0.2, 0.1], [0.6, -0.2, 0.3]]}),
            "sphere_grid",
            "'workspace.sphere_grid': each low must be below its high",
        ),
        (
            lambda d, n: d.update(workspace={n: [0.3]}),
            "cylinder",
            r"'workspace.cylinder' must be a list of 2 numbers > 0",
        ),
        (lambda d, n: d.update(workspace={n: 0.1}), "table", r"'workspace' may give \["),
    ],
)
def test_a_profile_mistake_is_refused_with_its_name(tmp_path, profile_data, mistake, name, message):
    mistake(profile_data, name)
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(profile_data))
    with pytest.raises(ValueError, match=message) as error:
        load_profile(path)
    assert str(path) in str(error.value)


def test_an_unknown_robot_is_refused_naming_the_shipped_ones():
    with pytest.raises(ValueError, match="no robot profile 'panda_arm'.*tric_arm_hand"):
        load_profile("panda_arm")


def test_tric_robot_check_reports_each_landmark_and_draws_them(tmp_path, capsys):
    picture = tmp_path / "landmarks.png"
    assert robot_check.main(["--samples", "3", "--picture", str(picture)]) == 0
    out = capsys.readouterr().out
    assert "robot profile 'tric_arm_hand'" in out and "over 3 random configurations" in out
    assert "finger_3_tip" in out and "problems: none" in out
    assert picture.read_bytes().startswith(b"\x89PNG")


def test_tric_robot_check_refuses_a_profile_naming_why(tmp_path, profile_data, capsys):
    profile_data["fingers"][2]["middle"] = "finger_3_center"
    path = tmp_path / "robot.yaml"
    path.write_text(yaml.safe_dump(profile_data))
    assert robot_check.main([str(path)]) == 2
    assert "finger 3 middle: frame 'finger_3_center' is not a link" in capsys.readouterr().err
    assert robot_check.main(["no_robot"]) == 2
    assert "no robot profile 'no_robot'" in capsys.readouterr().err
