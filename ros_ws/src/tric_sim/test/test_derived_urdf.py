"""A URDF derived from another (tric_sim.world.derived_urdf): the source's links and joints kept,
its collision primitives drawn as visuals, the profile's frames added as fixed links with a
negligible inertial, a link's collision geometry replaced by the primitives the profile gives; a
frame on a link the source lacks, or named as one of its links, and a malformed primitive refused;
and the Panda's, derived from example-robot-data by make setup, loads and rests on the table."""

import pathlib
import xml.etree.ElementTree as ET

import pytest

from tric_sim.physics.bullet import pb
from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.world import situations
from tric_sim.world.derived_urdf import derived_urdf, source_file
from tric_sim.world.robot_model import RobotModel

SOURCE = pathlib.Path(__file__).resolve().parent / "data" / "slider_gripper.urdf"


def test_a_derived_urdf_keeps_the_source_and_adds_the_frames():
    frames = {"probe": {"parent": "hand", "xyz": [0.0, 0.0, 0.1], "rpy": [0.0, 0.0, 1.5]}}
    root = ET.fromstring(derived_urdf(SOURCE, frames).split("\n", 2)[2])
    source = ET.parse(SOURCE).getroot()
    names = {link.get("name") for link in root.iter("link")}
    assert names == {link.get("name") for link in source.iter("link")} | {"probe"}
    joint = next(j for j in root.iter("joint") if j.get("name") == "probe_joint")
    assert joint.get("type") == "fixed" and joint.find("parent").get("link") == "hand"
    assert joint.find("origin").get("xyz") == "0.0 0.0 0.1"
    probe = next(link for link in root.iter("link") if link.get("name") == "probe")
    assert float(probe.find("inertial/mass").get("value")) == 0.001  # PyBullet's default: 1 kg
    for link in root.iter("link"):
        visuals, collisions = link.findall("visual"), link.findall("collision")
        assert len(visuals) == len(collisions)
        for visual, collision in zip(visuals, collisions):
            shapes = [[(c.tag, c.attrib) for c in x.find("geometry")] for x in (visual, collision)]
            assert shapes[0] == shapes[1] and visual.find("material") is not None


@pytest.mark.parametrize(
    "frames, message",
    [
        ({"probe": {"parent": "wrist"}}, "frame 'probe': its parent must be a link"),
        ({"hand": {"parent": "link_c"}}, "frame 'hand' is a link of slider_gripper.urdf already"),
    ],
)
def test_a_frame_that_cannot_be_added_is_refused(frames, message):
    with pytest.raises(ValueError, match=message):
        derived_urdf(SOURCE, frames)


def test_a_link_s_collision_geometry_is_replaced_by_the_profile_s_primitives():
    collisions = {
        "hand": [
            {"box": [0.04, 0.1, 0.02], "xyz": [0.0, 0.0, 0.01]},
            {"sphere": 0.02},
            {"cylinder": [0.01, 0.05], "rpy": [1.5, 0.0, 0.0]},
        ]
    }
    root = ET.fromstring(derived_urdf(SOURCE, {}, collisions).split("\n", 2)[2])
    hand = next(link for link in root.iter("link") if link.get("name") == "hand")
    shapes = [
        (c.find("geometry")[0].tag, c.find("geometry")[0].attrib) for c in hand.iter("collision")
    ]
    assert shapes == [
        ("box", {"size": "0.04 0.1 0.02"}),
        ("sphere", {"radius": "0.02"}),
        ("cylinder", {"radius": "0.01", "length": "0.05"}),
    ]
    assert [c.find("origin").get("xyz") for c in hand.iter("collision")][0] == "0.0 0.0 0.01"
    assert len(hand.findall("visual")) == 3  # drawn as they collide


@pytest.mark.parametrize(
    "collisions, message",
    [
        ({"wrist": [{"sphere": 0.02}]}, "collisions: 'wrist' is not a link of slider_gripper"),
        ({"hand": []}, "collisions: 'hand' takes a list of primitives"),
        ({"hand": [{"cone": 0.02}]}, r"collisions: hand\[0\]: give one of box, sphere or cylinder"),
        ({"hand": [{"box": [0.1, 0.1]}]}, r"collisions: hand\[0\]: box takes 3 positive size"),
        ({"hand": [{"sphere": -0.1}]}, r"collisions: hand\[0\]: sphere takes 1 positive size"),
    ],
)
def test_a_malformed_collision_primitive_is_refused(collisions, message):
    with pytest.raises(ValueError, match=message):
        derived_urdf(SOURCE, {}, collisions)


def test_a_source_in_a_missing_distribution_is_refused(tmp_path):
    with pytest.raises(ValueError, match="the distribution 'no-such-robots' is not installed"):
        source_file("no-such-robots:share/robot.urdf", tmp_path / "robot.yaml")
    with pytest.raises(ValueError, match="the source URDF .* does not exist"):
        source_file("missing.urdf", tmp_path / "robot.yaml")


def test_the_panda_derived_by_make_setup_loads():
    robot = RobotModel("panda")
    assert robot.n_joints == 8 and [m.name for m in robot.mimic_joints] == ["panda_finger_joint2"]
    assert robot.profile.closing_signs == {"panda_finger_joint1": -1.0}
    assert "Derived by `python -m tric_sim.world.derived_urdf`" in robot.urdf_path.read_text()


def test_the_panda_s_mounted_link_never_collides_with_the_table_in_the_simulator():
    """panda_link1 rests on the table with the base (its coarse model reaches 9 cm below the base's
    plane): PyBullet reports no contact between them (before: 9 cm deep, holding joint 1)."""
    robot = RobotModel("panda")
    world = PhysicsWorld(robot)
    try:
        world.reset(situations.sphere("mounted", (0.5, 0.0, 0.3)))
        world.step()
        link1, table = world.link_index["panda_link1"], world.bodies["table"]
        assert link1 in world.mounted_links and -1 in world.mounted_links
        client = world.client
        assert pb.getContactPoints(world.robot_id, table, link1, physicsClientId=client) == ()
        pb.setCollisionFilterPair(world.robot_id, table, link1, -1, 1, physicsClientId=client)
        world.step()  # the pair enabled again: 9 cm deep
        deepest = min(
            p[8] for p in pb.getContactPoints(world.robot_id, table, link1, physicsClientId=client)
        )
        assert deepest < -0.05
    finally:
        world.close()
