"""Waiting on topics from one's own thread (tric_sim.lockstep): StateStream returns the newest joint
state after a stamp together with its period's object poses, skips old and malformed states, and
gives up after its timeout; command_msg answers a state's stamp. Units: rad, m; stamps in ns."""

import time

import numpy as np
import pytest
import rclpy
from rclpy.context import Context
from rclpy.node import Node
from sensor_msgs.msg import JointState

from tric_msgs.msg import ObjectPoses
from tric_sim import messages
from tric_sim.lockstep import StateStream, command_msg
from tric_sim.ros_util import STATE_QOS

JOINTS = ("a", "b")
PERIOD_NS = 10_000_000
#: Wall seconds the published messages are given to reach the stream's subscriptions, so that one
#: poll takes them all.
DELIVERY_S = 0.5
SPHERE = {"sphere": (np.array([0.5, 0.1, 0.2]), np.array([0.0, 0.0, 0.0, 1.0]))}


@pytest.fixture
def graph():
    """(publisher of /joint_states, publisher of /object_poses, a StateStream) on a context of
    their own, the stream's subscriptions matched."""
    context = Context()
    rclpy.init(context=context)
    node = Node("lockstep_test_publisher", context=context)
    states = node.create_publisher(JointState, "/joint_states", STATE_QOS)
    poses = node.create_publisher(ObjectPoses, "/object_poses", STATE_QOS)
    stream = StateStream(context, "lockstep_test_stream", JOINTS, STATE_QOS)
    deadline = time.monotonic() + 10.0
    while states.get_subscription_count() < 1 or poses.get_subscription_count() < 1:
        assert time.monotonic() < deadline, "the stream's subscriptions were not matched"
        time.sleep(0.01)
    yield states, poses, stream
    stream.destroy()
    node.destroy_node()
    context.try_shutdown()


def state(names, positions, stamp_ns):
    return messages.joint_state_msg(names, positions, [0.0] * len(positions), stamp_ns)


def test_the_newest_state_comes_with_its_period_s_poses_in_the_stream_s_joint_order(graph):
    states, poses, stream = graph
    states.publish(state(("b", "a"), [0.2, 0.1], PERIOD_NS))
    states.publish(state(("b", "a"), [0.4, 0.3], 2 * PERIOD_NS))
    poses.publish(messages.object_poses_msg(SPHERE, 2 * PERIOD_NS))
    time.sleep(DELIVERY_S)
    stamp, q = stream.next_state(5.0)
    assert stamp == 2 * PERIOD_NS and q.tolist() == [0.3, 0.4]
    assert stream.poses_stamp_ns == 2 * PERIOD_NS
    np.testing.assert_array_equal(stream.poses["sphere"][0], SPHERE["sphere"][0])


def test_old_and_malformed_states_are_skipped_until_the_timeout(graph):
    states, poses, stream = graph
    poses.publish(messages.object_poses_msg(SPHERE, 2 * PERIOD_NS))
    states.publish(state(JOINTS, [0.1, 0.2], PERIOD_NS))  # not after after_ns
    states.publish(state(("a",), [0.1], 2 * PERIOD_NS))  # joint b missing
    time.sleep(DELIVERY_S)
    start = time.monotonic()
    assert stream.next_state(0.5, after_ns=PERIOD_NS) is None
    assert time.monotonic() - start >= 0.5 and stream.rejected == 1


def test_a_command_answers_the_state_s_stamp():
    msg = command_msg(JOINTS, np.array([0.5, -0.25]), 3 * PERIOD_NS)
    assert list(msg.name) == list(JOINTS) and list(msg.position) == [0.5, -0.25]
    assert messages.time_ns(msg.header.stamp) == 3 * PERIOD_NS
