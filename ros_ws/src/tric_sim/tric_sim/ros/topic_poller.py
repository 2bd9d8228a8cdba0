"""Waiting on topics from a thread of one's own: the fast path of lockstep simulation.

In lockstep every control period is a round trip: the simulator publishes the state, a commander
answers with a command, the simulator steps. rclpy's executors rebuild their wait set in Python for
each message they dispatch, which costs a few hundred microseconds per hop on a 2-core machine. A
TopicPoller instead keeps its subscriptions on a helper node that no executor spins and waits on
them directly with rclpy's wait set (as rclpy.wait_for_message does), from the caller's thread. The
node that owns the poller keeps its executor for everything else (services, actions, parameters).
"""

import threading
import time

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.task import Future
from sensor_msgs.msg import JointState

from tric_msgs.msg import ObjectPoses
from tric_sim.ros import messages


class TopicPoller:
    """Subscriptions polled by their owner's thread.

    Args:
        context: the rclpy context of the owning node.
        name: name of the helper node (visible in the ROS graph).
        topics: {key: (message type, topic name, QoS profile)}.
    """

    def __init__(self, context, name: str, topics: dict):
        self._node = Node(
            name, context=context, start_parameter_services=False, enable_rosout=False
        )
        self._context = context
        self._subscriptions = {
            key: self._node.create_subscription(
                msg_type,
                topic,
                lambda _: None,
                qos,
                event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False),
            )
            for key, (msg_type, topic, qos) in topics.items()
        }
        self._wait_set = _rclpy.WaitSet(len(topics), 0, 0, 0, 0, 0, context.handle)

    def poll(self, timeout_s: float) -> dict:
        """Wait up to timeout_s for messages on any topic; returns {key: [messages, oldest first]}
        (every key present, lists possibly empty)."""
        self._wait_set.clear_entities()
        for subscription in self._subscriptions.values():
            self._wait_set.add_subscription(subscription.handle)
        self._wait_set.wait(int(timeout_s * 1e9))
        received = {}
        for key, subscription in self._subscriptions.items():
            messages = []
            while True:
                taken = subscription.handle.take_message(subscription.msg_type, subscription.raw)
                if taken is None:
                    break
                messages.append(taken[0])
            received[key] = messages
        return received

    def destroy(self) -> None:
        self._node.destroy_node()


async def run_in_thread(node: Node, function, *args):
    """Run function(*args) in a new thread and await its return value (or its exception) from a
    coroutine of node's executor, without blocking that executor: a guard condition wakes it when
    the thread is done."""
    outcome = {}
    done = Future()

    def finish():
        if not done.done():
            done.set_result(None)

    guard = node.create_guard_condition(finish)

    def target():
        try:
            outcome["value"] = function(*args)
        except BaseException as error:  # re-raised in the awaiting coroutine
            outcome["error"] = error
        guard.trigger()

    thread = threading.Thread(
        target=target, daemon=True, name=getattr(function, "__name__", "worker")
    )
    thread.start()
    await done
    thread.join()
    node.destroy_guard_condition(guard)
    if "error" in outcome:
        raise outcome["error"]
    return outcome["value"]


class StateStream:
    """The robot's joint states and the objects' poses, read by a commander's own thread.

    next_state() waits for the newest /joint_states message and returns its stamp (ns) and the
    positions in the order of joint_names; poses holds the latest /object_poses as {name: (position,
    xyzw)}. Malformed messages are skipped (and counted in `rejected`).
    """

    def __init__(self, context, name: str, joint_names, qos):
        self.joint_names = tuple(joint_names)
        self.poses = {}
        self.poses_stamp_ns = -1
        self.rejected = 0
        self._poller = TopicPoller(
            context,
            name,
            {
                "state": (JointState, "/joint_states", qos),
                "poses": (ObjectPoses, "/object_poses", qos),
            },
        )

    def next_state(self, timeout_s: float, after_ns: int = -1):
        """(stamp_ns, q) of the newest joint state stamped after after_ns that arrives within
        timeout_s of wall time, or None. The simulator publishes a period's object poses before its
        joint state; when the state comes first, this waits (within the same timeout) for the poses
        of its period too, so that poses holds them when it returns."""
        deadline = time.monotonic() + timeout_s
        newest = None
        while True:
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                return newest
            received = self._poller.poll(min(remaining, 0.05))
            for msg in received["poses"]:
                try:
                    self.poses = messages.object_poses_from_msg(msg)
                    self.poses_stamp_ns = messages.time_ns(msg.header.stamp)
                except ValueError:
                    self.rejected += 1
            for msg in received["state"]:
                stamp = messages.time_ns(msg.header.stamp)
                if stamp <= after_ns or (newest is not None and stamp <= newest[0]):
                    continue
                try:
                    newest = (stamp, messages.joint_positions_from_msg(msg, self.joint_names))
                except ValueError:
                    self.rejected += 1
            if newest is not None and self.poses_stamp_ns >= newest[0]:
                return newest

    def destroy(self) -> None:
        self._poller.destroy()


def command_msg(joint_names, q, stamp_ns: int) -> JointState:
    """A /joint_command message: position targets q (rad) for joint_names, answering the state
    stamped stamp_ns (lockstep)."""
    msg = JointState(name=list(joint_names), position=[float(v) for v in q])
    msg.header.stamp = messages.time_msg(stamp_ns)
    return msg
