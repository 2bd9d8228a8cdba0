"""Fixtures for in-process ROS 2 tests: a fresh rclpy context and executor per test."""

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import MultiThreadedExecutor


@pytest.fixture
def ros_context():
    """An initialized rclpy Context of its own, shut down after the test."""
    context = Context()
    rclpy.init(context=context)
    yield context
    context.try_shutdown()


@pytest.fixture
def executor(ros_context):
    """A MultiThreadedExecutor on the test's context; nodes added to it are destroyed afterwards."""
    exe = MultiThreadedExecutor(num_threads=4, context=ros_context)
    yield exe
    for node in list(exe.get_nodes()):
        exe.remove_node(node)
        node.destroy_node()
    exe.shutdown()
