"""The visualizer node ("visualizer"): the robot, the scene and the controller's value, live, for
RViz, foxglove_bridge and Foxglove. A thin shell around tric_sim.viz.scene_view (what to draw),
tric_sim.viz.scene_messages (as ROS messages) and tric_sim.viz.foxglove_view (as a Foxglove server).

Subscribes /situation (tric_msgs/Situation, latched), and, keeping only the newest message of each,
/joint_states, /object_poses and the controller's status (`status_topic`,
tric_msgs/ControllerStatus). Publishes:
- /robot_description (std_msgs/String, the URDF, latched) and /scene_markers
  (visualization_msgs/MarkerArray: the robot's collision primitives in namespace "robot", the
  scene's bodies in "scene"; latched, re-sent when the situation changes);
- /tf_static (latched) and, `rate_hz` times per wall-clock second while joint states come, /tf
  (tf2_msgs/TFMessage: every URDF joint, and "world" -> each object of /object_poses), stamped with
  the joint state's time. tf2_msgs is not on PyPI: in the pip environment the frames go over the
  Foxglove server only (and into bags, tric_learning.scene_recording); on a stock ROS 2 install RViz
  shows everything (fixed frame "world", RobotModel on /robot_description, MarkerArray on
  /scene_markers).
- unless `foxglove` is false, a Foxglove WebSocket server on `foxglove_host`:`foxglove_port`
  (tric_sim.viz.foxglove_view: /scene, /tf, /controller/status). In-process tools pass one server to
  the node instead (view=), so that it lives as long as the tool's run.

Parameters: rate_hz (30, in [1, 200]), foxglove (true), foxglove_host ("127.0.0.1": this machine
only; "0.0.0.0" for every interface), foxglove_port (8765; 0: a free port, logged), status_topic
("/controller/status").
"""

import sys

from rclpy.clock import Clock, ClockType
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState
from std_msgs.msg import String
from visualization_msgs.msg import MarkerArray

from tric_msgs.msg import ControllerStatus, ObjectPoses
from tric_msgs.msg import Situation as SituationMsg
from tric_sim.ros import messages
from tric_sim.ros.graph import LATCHED_QOS, run_node
from tric_sim.ros.parameters import Range, declare, declare_robot
from tric_sim.ros.topic_poller import TopicPoller
from tric_sim.viz import scene_messages, scene_view

try:
    from tf2_msgs.msg import TFMessage
except ImportError:  # the pip environment: tf2_msgs is not on PyPI
    TFMessage = None

#: The streams are read at rate_hz: only their newest message matters.
NEWEST_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)


class VisualizerNode(Node):
    """Publishes the scene for viewers (see the module docstring). view: a
    tric_sim.viz.foxglove_view .FoxgloveView to use instead of starting one (the caller closes
    it)."""

    def __init__(self, view=None, **kwargs):
        super().__init__("visualizer", **kwargs)
        rate = declare(
            self,
            "rate_hz",
            30.0,
            "wall-clock updates per second of /tf and the Foxglove view",
            Range(1.0, 200.0),
        )
        serve = declare(
            self, "foxglove", True, "serve a Foxglove WebSocket (ignored when a tool passes one)"
        )
        host = declare(self, "foxglove_host", "127.0.0.1", "address the Foxglove server listens on")
        port = declare(
            self,
            "foxglove_port",
            8765,
            "TCP port of the Foxglove server (0: a free one)",
            Range(0, 65535),
        )
        status_topic = declare(
            self, "status_topic", "/controller/status", "the controller's status topic"
        )
        self.robot_view = scene_view.RobotView(declare_robot(self))
        self.situation = None
        self._poses = {}
        self._stamp_ns = 0
        self._owned_view = None
        if view is None and serve:
            from tric_sim.viz.foxglove_view import (
                FoxgloveView,  # only now: nothing of foxglove when it is off
            )

            view = self._owned_view = FoxgloveView(host, port)  # ValueError: the port is taken
        self.view = view

        self.description_pub = self.create_publisher(String, "/robot_description", LATCHED_QOS)
        self.markers_pub = self.create_publisher(MarkerArray, "/scene_markers", LATCHED_QOS)
        self.tf_pub = self.tf_static_pub = None
        if TFMessage is not None:
            self.tf_pub = self.create_publisher(TFMessage, "/tf", QoSProfile(depth=100))
            self.tf_static_pub = self.create_publisher(TFMessage, "/tf_static", LATCHED_QOS)
            self.tf_static_pub.publish(
                TFMessage(transforms=scene_messages.transform_msgs(self.robot_view.static, 0))
            )
        self.description_pub.publish(scene_messages.robot_description_msg(self.robot_view.urdf))
        self._show_scene()
        self.create_subscription(SituationMsg, "/situation", self._on_situation, LATCHED_QOS)
        self._streams = TopicPoller(
            self.context,
            "visualizer_streams",
            {
                "state": (JointState, "/joint_states", NEWEST_QOS),
                "poses": (ObjectPoses, "/object_poses", NEWEST_QOS),
                "status": (ControllerStatus, status_topic, NEWEST_QOS),
            },
        )
        self.create_timer(1.0 / rate, self._on_timer, clock=Clock(clock_type=ClockType.STEADY_TIME))
        topics = "/robot_description, /scene_markers" + (
            ", /tf" if self.tf_pub is not None else " (no /tf: tf2_msgs is not installed)"
        )
        self.get_logger().info(
            f"visualizing at {rate:g} Hz on {topics}"
            + (f"; Foxglove server on {view.url}" if self._owned_view is not None else "")
        )

    def destroy_node(self):
        self._streams.destroy()
        if self._owned_view is not None:
            self._owned_view.close()
        return super().destroy_node()

    def _on_situation(self, msg: SituationMsg):
        try:
            situation = messages.situation_from_msg(msg)
        except ValueError as error:
            self.get_logger().warning(f"ignored /situation '{msg.name}': {error}")
            return
        self.situation = situation
        self._poses = scene_view.initial_object_poses(situation)
        self._show_scene()

    def _show_scene(self):
        primitives = list(self.robot_view.primitives)
        if self.situation is not None:
            primitives += scene_view.scene_primitives(self.situation)
        self.markers_pub.publish(scene_messages.marker_array(primitives, self._stamp_ns))
        if self.view is not None:
            self.view.show_scene(primitives, self._stamp_ns)

    def _on_timer(self):
        """The newest joint state, poses and status: /tf and the Foxglove view."""
        newest = {key: msgs[-1] for key, msgs in self._streams.poll(0.0).items() if msgs}
        if "poses" in newest:
            try:
                self._poses = messages.object_poses_from_msg(newest["poses"])
            except ValueError as error:
                self.get_logger().warning(
                    f"ignored /object_poses: {error}", throttle_duration_sec=5.0
                )
        if "state" in newest:
            try:
                q = messages.joint_positions_from_msg(
                    newest["state"], self.robot_view.robot.joint_names
                )
            except ValueError as error:
                self.get_logger().warning(
                    f"ignored /joint_states: {error}", throttle_duration_sec=5.0
                )
            else:
                self._stamp_ns = messages.time_ns(newest["state"].header.stamp)
                self._show_frames(q)
        if "status" in newest and self.view is not None:
            status = newest["status"]
            self.view.show_status(
                scene_messages.status_fields(status), messages.time_ns(status.header.stamp)
            )

    def _show_frames(self, q):
        moving = [self.robot_view.transforms(q), scene_view.object_transforms(self._poses)]
        if self.tf_pub is not None:
            self.tf_pub.publish(
                TFMessage(
                    transforms=[
                        msg
                        for transforms in moving
                        for msg in scene_messages.transform_msgs(transforms, self._stamp_ns)
                    ]
                )
            )
        if self.view is not None:
            self.view.show_transforms([self.robot_view.static] + moving, self._stamp_ns)


def main(args=None):
    return run_node(VisualizerNode, "visualizer", args)


if __name__ == "__main__":
    sys.exit(main())
