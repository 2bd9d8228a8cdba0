"""The controller node's realtime mode: a timer at control_rate_hz on the node clock commands from
the latest joint state. When that state is older than 3 control periods (or the objects' poses are
missing) the input is stale: the node commands the last measured positions (approached at the
velocity bound) with status HOLDING, does not step the controller, and resumes when fresh states
arrive. A watchdog on the wall clock ends the episode on a cancel request, a new scene or the state
timeout."""

import time

from rclpy.clock import Clock, ClockType
from sensor_msgs.msg import JointState

from tric_control.loops.episode import POLL_S, Episode
from tric_msgs.msg import ControllerStatus, ObjectPoses
from tric_sim.ros import messages
from tric_sim.ros.graph import STATE_QOS


class RealtimeLoop:
    """The realtime inputs, control timer and watchdog of node (a
    tric_control.controller_node.ControllerNode), which ticks through node._tick."""

    def __init__(self, node):
        self.node = node
        # (stamp_ns, q, received wall time) of the newest joint state
        self.latest = None
        self.poses = {}
        self.episode = None  # the running episode
        node.create_subscription(JointState, "/joint_states", self._on_joint_state, STATE_QOS)
        node.create_subscription(ObjectPoses, "/object_poses", self._on_object_poses, STATE_QOS)
        node.create_timer(node.period, self._on_control_timer)
        node.create_timer(POLL_S, self._on_watchdog, clock=Clock(clock_type=ClockType.STEADY_TIME))

    async def run(self, episode: Episode):
        """The episode run to its end by the timer: (outcome, message)."""
        self.episode = episode
        try:
            return await episode.done
        finally:
            self.episode = None

    def stop(self) -> None:
        """End the running episode: the node is shutting down."""
        episode = self.episode
        if episode is not None:
            episode.finish("failed", "the controller is shutting down")

    def destroy(self) -> None:
        pass

    def _on_joint_state(self, msg: JointState):
        try:
            q = messages.joint_positions_from_msg(msg, self.node.robot.joint_names)
        except ValueError as error:
            self.node.get_logger().warning(
                f"ignored /joint_states: {error}", throttle_duration_sec=1.0
            )
            return
        self.latest = (messages.time_ns(msg.header.stamp), q, time.monotonic())

    def _on_object_poses(self, msg: ObjectPoses):
        try:
            self.poses = messages.object_poses_from_msg(msg)
        except ValueError as error:
            self.node.get_logger().warning(
                f"ignored /object_poses: {error}", throttle_duration_sec=1.0
            )

    def _on_control_timer(self):
        """One runner step from the latest state (a hold when it is stale or the objects' poses are
        missing), or idle status."""
        node = self.node
        now_ns = node.get_clock().now().nanoseconds
        episode = self.episode
        if episode is None or episode.done.done():
            node._status(ControllerStatus.IDLE, now_ns)
            return
        latest = self.latest
        if latest is None:
            node._status(ControllerStatus.HOLDING, now_ns, episode)
            return
        stamp, q, _ = latest
        try:
            outcome = node._tick(episode, stamp, q, self.poses, now_ns, now_ns)
        except Exception as error:
            outcome = (
                "failed",
                str(error)
                if isinstance(error, RuntimeError)
                else f"internal error: {type(error).__name__}: {error}",
            )
        if outcome:
            episode.finish(*outcome)

    def _on_watchdog(self):
        """Wall clock: cancel requests and the state timeout of the running episode."""
        node = self.node
        episode = self.episode
        if episode is None or episode.done.done():
            return
        if episode.goal_handle.is_cancel_requested:
            episode.finish("canceled", "canceled")
            return
        if node.scene is not episode.scene:
            episode.finish("failed", "the scene was reset during the episode")
            return
        latest = self.latest
        last_wall = max(episode.wall_start, latest[2]) if latest is not None else episode.wall_start
        if time.monotonic() - last_wall > node.state_timeout:
            episode.finish(
                "failed", f"no joint states for {node.state_timeout:g} s: is the robot running?"
            )
