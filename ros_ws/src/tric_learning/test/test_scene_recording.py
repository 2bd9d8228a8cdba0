"""The scene topics of bags (tric_learning.scene_recording): TFMessage's CDR against the generic
serializer and two readers, and BagWriter's topics of types not installed here."""

import numpy as np
import pytest
from mcap.records import Schema
from mcap_ros2.decoder import DecoderFactory
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosidl_parser.definition import NamespacedType, UnboundedSequence
from std_msgs.msg import String

from tric_learning import bags
from tric_learning.scene_recording import TF_DEFINITION, TF_TYPE, tf_message_cdr
from tric_sim.viz import scene_messages, scene_view
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

STAMP_NS = 12_345_678_901


class StandInTFMessage:
    """tf2_msgs/msg/TFMessage as rclpy would generate it, for the generic serializer."""

    SLOT_TYPES = (UnboundedSequence(NamespacedType(["geometry_msgs", "msg"], "TransformStamped")),)

    def __init__(self, transforms):
        self.transforms = transforms

    @staticmethod
    def get_fields_and_field_types():
        return {"transforms": "sequence<geometry_msgs/TransformStamped>"}


@pytest.fixture(scope="module")
def transform_sets():
    robot = RobotModel()
    view = scene_view.RobotView(robot)
    q = np.random.default_rng(0).uniform(robot.lower, robot.upper)
    poses = scene_view.initial_object_poses(situations.dataset("box_test")[0])
    return [view.static, view.transforms(q), scene_view.object_transforms(poses)]


def test_tf_cdr_is_the_generic_serialization(transform_sets):
    messages = [m for t in transform_sets for m in scene_messages.transform_msgs(t, STAMP_NS)]
    assert tf_message_cdr(transform_sets, STAMP_NS) == bags.serialize_cdr(
        StandInTFMessage(messages)
    )


def test_tf_cdr_reads_back_as_tf2_msgs(transform_sets):
    """Both our bag reader (mcap_ros2) and rosbags decode the bytes with the definition we store."""
    data = tf_message_cdr(transform_sets, STAMP_NS)
    schema = Schema(
        id=1,
        name=TF_TYPE,
        encoding="ros2msg",
        data=bags.message_definition(TF_TYPE, TF_DEFINITION).encode(),
    )
    ours = DecoderFactory().decoder_for("cdr", schema)(data)
    store = get_typestore(Stores.ROS2_JAZZY)
    store.register(get_types_from_msg(TF_DEFINITION, TF_TYPE))
    theirs = store.deserialize_cdr(data, TF_TYPE)
    expected = [
        (p, c, pos, o)
        for t in transform_sets
        for p, c, pos, o in zip(t.parents, t.children, t.positions, t.orientations)
    ]
    for decoded in (ours.transforms, theirs.transforms):
        assert len(decoded) == len(expected)
        for got, (parent, child, position, orientation) in zip(decoded, expected):
            assert (got.header.frame_id, got.child_frame_id) == (parent, child)
            assert got.header.stamp.sec * 10**9 + got.header.stamp.nanosec == STAMP_NS
            t, r = got.transform.translation, got.transform.rotation
            assert np.allclose(
                [t.x, t.y, t.z, r.x, r.y, r.z, r.w], np.concatenate([position, orientation])
            )


def test_writer_takes_a_type_by_its_definition(tmp_path, transform_sets):
    path = tmp_path / "tf.mcap"
    with bags.BagWriter(path) as writer:
        writer.add_topic_definition("/tf", TF_TYPE, TF_DEFINITION)
        writer.add_topic("/robot_description", String, latched=True)
        with pytest.raises(TypeError, match="as CDR bytes"):
            writer.write("/tf", String(data="x"), 1)
        with pytest.raises(ValueError, match="not added with add_topic_definition"):
            writer.write_cdr("/robot_description", b"\x00\x01\x00\x00", 1)
        with pytest.raises(ValueError, match="added already"):
            writer.add_topic_definition("/tf", TF_TYPE, TF_DEFINITION)
        writer.write_cdr("/tf", tf_message_cdr(transform_sets, STAMP_NS), STAMP_NS)
    info = bags.bag_info(path)
    assert info.topics["/tf"].type_name == TF_TYPE and info.topics["/tf"].message_count == 1
    [message] = bags.read_bag(path, topics=["/tf"])
    assert message.stamp_ns == STAMP_NS and len(message.message.transforms) == sum(
        map(len, transform_sets)
    )
