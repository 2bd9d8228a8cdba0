"""Robot profiles: the paper's robot as data, every shipped profile checked against its URDF in
Pinocchio and PyBullet, and each kind of mistake in a profile refused with its name."""

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pybullet as pb
import pytest
import yaml

from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.world import scene, situations
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


def test_the_hand_geometries_are_the_hand_links():
    robot = RobotModel()
    frames = robot.model.frames
    names = [frames[g.parentFrame].name for g in robot.collision_model.geometryObjects]
    hand = {name for name, on_hand in zip(names, robot.hand_geometries) if on_hand}
    assert "palm_link" in hand and "finger_1_distal_link" in hand
    assert not any(name.startswith("arm_") for name in hand)
    assert all(name in hand for name in names if name.startswith(("finger_", "palm")))


def _landmarks(profile) -> set:
    fingers = profile.fingers
    return {
        profile.base,
        profile.palm,
        *profile.lid_fingertips,
        *(frame for f in fingers for frame in (f.tip, f.middle, f.base, *f.links)),
    }


def _fixed_chains(urdf_path) -> dict:
    """URDF child link -> (parent link, fixed placement) of each fixed joint."""
    chains = {}
    for joint in ET.parse(urdf_path).getroot().iter("joint"):
        if joint.get("type") != "fixed":
            continue
        origin = joint.find("origin")
        xyz = [
            float(v)
            for v in (origin.get("xyz", "0 0 0") if origin is not None else "0 0 0").split()
        ]
        rpy = [
            float(v)
            for v in (origin.get("rpy", "0 0 0") if origin is not None else "0 0 0").split()
        ]
        placement = pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz))
        chains[joint.find("child").get("link")] = (joint.find("parent").get("link"), placement)
    return chains


def _pybullet_placement(world, chains, base, frame) -> pin.SE3:
    """A frame's world placement as PyBullet has it: its link, or the simulated link that carries
    it (PyBullet merges fixed links) composed with the fixed joints in between."""
    offset = pin.SE3.Identity()
    while frame not in world.link_index and frame != base:
        frame, placement = chains[frame]
        offset = placement * offset
    if frame == base:  # PyBullet places the base by its centre of mass
        position, orientation = pb.getBasePositionAndOrientation(
            world.robot_id, physicsClientId=world.client
        )
        inertial = pb.getDynamicsInfo(world.robot_id, -1, physicsClientId=world.client)
        centre = scene.se3(np.array(inertial[3]), np.array(inertial[4]))
        offset = centre.inverse() * offset
    else:
        state = pb.getLinkState(
            world.robot_id,
            world.link_index[frame],
            computeForwardKinematics=True,
            physicsClientId=world.client,
        )
        position, orientation = state[4], state[5]
    return scene.se3(np.array(position), np.array(orientation)) * offset


@pytest.mark.parametrize("name", SHIPPED)
def test_every_profile_s_landmarks_agree_in_pinocchio_and_pybullet(name):
    """Over random configurations, each landmark frame of the profile, as Pinocchio places it and
    as PyBullet does, to 1e-6 m and rad; and the collision pairs are consistent: none between a
    link and itself or its neighbour, none the SRDF disables, and the SRDF names URDF links."""
    robot = RobotModel(name)
    profile = robot.profile
    chains = _fixed_chains(profile.urdf_path)
    world = PhysicsWorld(robot)
    try:
        world.reset(situations.sphere("agreement", (0.6, 0.0, 0.35)))
        rng = np.random.default_rng(0)
        worst = 0.0
        for _ in range(10):
            q = rng.uniform(robot.lower, robot.upper)
            for joint, angle in robot.urdf_joint_positions(q).items():
                index = (
                    world.actuated[robot.joint_names.index(joint)]
                    if joint in robot.joint_names
                    else next(m[0] for m in world.mimics)
                )
                pb.resetJointState(world.robot_id, index, angle, physicsClientId=world.client)
            robot.forward(q)
            for frame in _landmarks(profile):
                expected = robot.frame_placement(frame)
                got = _pybullet_placement(world, chains, profile.base, frame)
                worst = max(
                    worst,
                    np.abs(expected.translation - got.translation).max(),
                    np.linalg.norm(pin.log3(expected.rotation.T @ got.rotation)),
                )
        assert worst < 1e-6
    finally:
        world.close()
    links = {link.get("name") for link in ET.parse(profile.urdf_path).getroot().iter("link")}
    disabled = {
        frozenset((tag.get("link1"), tag.get("link2")))
        for tag in ET.parse(profile.srdf_path).getroot().iter("disable_collisions")
    }
    assert disabled and all(pair <= links for pair in disabled)
    geometries, model = robot.collision_model.geometryObjects, robot.model
    for pair in robot.collision_model.collisionPairs:
        a, b = geometries[pair.first], geometries[pair.second]
        assert a.parentJoint != b.parentJoint
        assert model.parents[a.parentJoint] != b.parentJoint
        assert model.parents[b.parentJoint] != a.parentJoint
        names = frozenset((model.frames[a.parentFrame].name, model.frames[b.parentFrame].name))
        assert names not in disabled


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
