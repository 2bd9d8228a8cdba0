"""Waiting on topics from one's own thread (tric_sim.ros.topic_poller): StateStream returns the
newest joint state after a stamp together with its period's object poses, skips old and malformed
states, and gives up after its timeout; command_msg answers a state's stamp. Units: rad, m; stamps
in ns."""

import threading

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.duration import Duration
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from sensor_msgs.msg import JointState

from tric_msgs.msg import ObjectPoses
from tric_sim.ros import messages
from tric_sim.ros.graph import STATE_QOS
from tric_sim.ros.topic_poller import StateStream, command_msg

JOINTS = ("a", "b")
PERIOD_NS = 10_000_000
#: Wall seconds after which a wait counts as a hang: it times nothing.
HANG_S = 120.0
SPHERE = {"sphere": (np.array([0.5, 0.1, 0.2]), np.array([0.0, 0.0, 0.0, 1.0]))}


@pytest.fixture
def graph():
    """(publisher of /joint_states, publisher of /object_poses, a StateStream) on a context of
    their own, once both publishers report the stream's subscriptions matched (their matched
    events)."""
    context = Context()
    rclpy.init(context=context)
    node = Node("lockstep_test_publisher", context=context)
    matched = {topic: threading.Event() for topic in ("/joint_states", "/object_poses")}

    def publisher(msg_type, topic):
        def on_matched(status):
            if status.current_count >= 1:
                matched[topic].set()

        return node.create_publisher(
            msg_type,
            topic,
            STATE_QOS,
            event_callbacks=PublisherEventCallbacks(matched=on_matched),
        )

    states, poses = publisher(JointState, "/joint_states"), publisher(ObjectPoses, "/object_poses")
    stream = StateStream(context, "lockstep_test_stream", JOINTS, STATE_QOS)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    while not all(event.is_set() for event in matched.values()):
        executor.spin_once(timeout_sec=HANG_S)  # returns on each event handled
    yield states, poses, stream
    executor.shutdown()
    stream.destroy()
    node.destroy_node()
    context.try_shutdown()


def delivered(*publishers):
    """Once every subscriber has acknowledged what publishers published (reliable QoS): a poll
    then takes it all."""
    for publisher in publishers:
        assert publisher.wait_for_all_acked(Duration(seconds=HANG_S)), "messages not delivered"


def state(names, positions, stamp_ns):
    return messages.joint_state_msg(names, positions, [0.0] * len(positions), stamp_ns)


def test_the_newest_state_comes_with_its_period_s_poses_in_the_stream_s_joint_order(graph):
    states, poses, stream = graph
    states.publish(state(("b", "a"), [0.2, 0.1], PERIOD_NS))
    states.publish(state(("b", "a"), [0.4, 0.3], 2 * PERIOD_NS))
    poses.publish(messages.object_poses_msg(SPHERE, 2 * PERIOD_NS))
    delivered(states, poses)
    stamp, q = stream.next_state(HANG_S)
    assert stamp == 2 * PERIOD_NS and q.tolist() == [0.3, 0.4]
    assert stream.poses_stamp_ns == 2 * PERIOD_NS
    np.testing.assert_array_equal(stream.poses["sphere"][0], SPHERE["sphere"][0])


def test_old_and_malformed_states_are_skipped_until_the_timeout(graph):
    states, poses, stream = graph
    poses.publish(messages.object_poses_msg(SPHERE, 2 * PERIOD_NS))
    states.publish(state(JOINTS, [0.1, 0.2], PERIOD_NS))  # not after after_ns
    states.publish(state(("a",), [0.1], 2 * PERIOD_NS))  # joint b missing
    delivered(states, poses)
    assert stream.next_state(0.1, after_ns=PERIOD_NS) is None
    assert stream.rejected == 1


def test_a_command_answers_the_state_s_stamp():
    msg = command_msg(JOINTS, np.array([0.5, -0.25]), 3 * PERIOD_NS)
    assert list(msg.name) == list(JOINTS) and list(msg.position) == [0.5, -0.25]
    assert messages.time_ns(msg.header.stamp) == 3 * PERIOD_NS
