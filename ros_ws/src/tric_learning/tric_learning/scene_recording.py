"""The scene topics of a bag, so that Foxglove (and `ros2 bag play` into RViz) shows the episode in
3D:

    /robot_description: std_msgs/String                 once, latched (the URDF)
    /tf_static:         tf2_msgs/TFMessage              once, latched (world -> base_link, fixed
                                                        joints)
    /scene_markers:     visualization_msgs/MarkerArray  once, latched (robot and scene primitives)
    /tf:                tf2_msgs/TFMessage              every TF_PERIOD of simulated time: the
                                                        moving joints and world -> each object

The frames and primitives are tric_sim.viz.scene_view's, the messages tric_sim.viz.scene_messages';
the live visualizer node publishes the same. tf2_msgs is not on PyPI: TFMessage ("geometry_msgs/
TransformStamped[] transforms") is written from its definition and its CDR bytes (tf_message_cdr),
and reads back as the real type everywhere (Foxglove, ros2 bag, rosbags).
"""

import struct

import numpy as np
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from tric_learning import bags
from tric_sim.viz import scene_messages, scene_view

TF_TYPE = "tf2_msgs/msg/TFMessage"
TF_DEFINITION = "geometry_msgs/TransformStamped[] transforms\n"
#: Simulated time between two /tf messages, s (25 Hz: smooth in Foxglove, cheap to record).
TF_PERIOD = 0.04
_CDR_HEADER = b"\x00\x01\x00\x00"
_COUNT = struct.Struct("<I")
_STAMP = struct.Struct("<iI")
_TRANSFORM = struct.Struct("<7d")


def tf_message_cdr(transform_sets, stamp_ns: int) -> bytes:
    """The CDR bytes (little endian, with the encapsulation header, as bags.serialize_cdr makes
    them) of a tf2_msgs/TFMessage of the transforms (tric_sim.viz.scene_view.Transforms), all
    stamped stamp_ns. Written field by field: a few times faster than the generic serializer on
    message objects."""
    sec, nanosec = divmod(int(stamp_ns), 1_000_000_000)
    count = sum(len(transforms) for transforms in transform_sets)
    payload = bytearray(_COUNT.pack(count))
    for transforms in transform_sets:
        values = np.concatenate([transforms.positions, transforms.orientations], axis=1).tolist()
        for parent, child, numbers in zip(transforms.parents, transforms.children, values):
            payload += bytes(-len(payload) % 4) + _STAMP.pack(sec, nanosec)
            for name in (parent, child):
                text = name.encode("utf-8")
                payload += bytes(-len(payload) % 4) + _COUNT.pack(len(text) + 1) + text + b"\0"
            payload += bytes(-len(payload) % 8) + _TRANSFORM.pack(*numbers)
    return _CDR_HEADER + bytes(payload)


class SceneTopics:
    """Writes the scene topics of one episode into writer (a bags.BagWriter): the latched ones at
    start_ns, and /tf with state() whenever TF_PERIOD of simulated time has passed."""

    def __init__(
        self,
        writer: bags.BagWriter,
        robot_view: scene_view.RobotView,
        situation,
        start_ns: int,
        period: float = TF_PERIOD,
    ):
        self.writer, self.robot_view = writer, robot_view
        self.period_ns = int(round(period * 1e9))
        self._next_ns = start_ns
        writer.add_topic("/robot_description", String, latched=True)
        writer.add_topic_definition("/tf_static", TF_TYPE, TF_DEFINITION, latched=True)
        writer.add_topic_definition("/tf", TF_TYPE, TF_DEFINITION)
        writer.add_topic("/scene_markers", MarkerArray, latched=True)
        writer.write(
            "/robot_description", scene_messages.robot_description_msg(robot_view.urdf), start_ns
        )
        writer.write_cdr("/tf_static", tf_message_cdr([robot_view.static], start_ns), start_ns)
        primitives = list(robot_view.primitives) + scene_view.scene_primitives(situation)
        writer.write("/scene_markers", scene_messages.marker_array(primitives, start_ns), start_ns)

    def state(self, stamp_ns: int, q, object_poses: dict) -> None:
        """A joint state q (n,) and the objects' poses at stamp_ns: /tf if one is due."""
        if stamp_ns < self._next_ns:
            return
        self._next_ns = stamp_ns + self.period_ns
        moving = [self.robot_view.transforms(q), scene_view.object_transforms(object_poses)]
        self.writer.write_cdr("/tf", tf_message_cdr(moving, stamp_ns), stamp_ns)
