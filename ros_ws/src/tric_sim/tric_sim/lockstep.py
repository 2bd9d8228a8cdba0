"""Waiting on topics from a thread of one's own: the fast path of lockstep simulation.

In lockstep every control period is a round trip: the simulator publishes the state, a commander
answers with a command, the simulator steps. rclpy's executors rebuild their wait set in Python for
each message they dispatch, which costs a few hundred microseconds per hop on a 2-core machine. A
TopicPoller instead keeps its subscriptions on a helper node that no executor spins and waits on them
directly with rclpy's wait set (as rclpy.wait_for_message does), from the caller's thread. The node
that owns the poller keeps its executor for everything else (services, actions, parameters).
"""

from rclpy.event_handler import SubscriptionEventCallbacks
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node


class TopicPoller:
    """Subscriptions polled by their owner's thread.

    Args:
        context: the rclpy context of the owning node.
        name: name of the helper node (visible in the ROS graph).
        topics: {key: (message type, topic name, QoS profile)}.
    """

    def __init__(self, context, name: str, topics: dict):
        self._node = Node(name, context=context, start_parameter_services=False, enable_rosout=False)
        self._context = context
        self._subscriptions = {
            key: self._node.create_subscription(
                msg_type, topic, lambda _: None, qos,
                event_callbacks=SubscriptionEventCallbacks(use_default_callbacks=False))
            for key, (msg_type, topic, qos) in topics.items()}
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
