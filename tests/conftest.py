"""Fixtures for in-process ROS 2 tests: a fresh rclpy context and a spinning executor per test."""

import threading
import time

import pytest
import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor


@pytest.fixture
def ros_context():
    """An initialized rclpy Context of its own, shut down after the test."""
    context = Context()
    rclpy.init(context=context)
    yield context
    context.try_shutdown()


@pytest.fixture
def executor(ros_context):
    """A SingleThreadedExecutor (the one `ros2 run` uses) on the test's context; nodes added to it
    are destroyed afterwards."""
    exe = SingleThreadedExecutor(context=ros_context)
    yield exe
    for node in list(exe.get_nodes()):
        exe.remove_node(node)
        node.destroy_node()
    exe.shutdown()


@pytest.fixture
def spin(executor):
    """spin(*nodes): add nodes to the test's executor and spin it in a background thread."""
    started = []

    def start(*nodes):
        for node in nodes:
            executor.add_node(node)
        if not started:
            thread = threading.Thread(target=executor.spin, daemon=True)
            thread.start()
            started.append(thread)
        return nodes[0] if len(nodes) == 1 else nodes

    return start


def wait_for(predicate, timeout=20.0, what="condition"):
    """Poll predicate() until it is truthy; its value, or an AssertionError after timeout s."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        value = predicate()
        if value:
            return value
        time.sleep(0.01)
    raise AssertionError(f"timed out after {timeout} s waiting for {what}")


def call(node, srv_type, name, request, timeout=30.0):
    """Call a service from node (spun elsewhere) and return the response."""
    client = node.create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=timeout), f"service {name} not available"
    response = client.call(request, timeout_sec=timeout)
    assert response is not None, f"service {name} did not answer in {timeout} s"
    node.destroy_client(client)
    return response


def run_action(node, action_type, name, goal, timeout=120.0):
    """Send a goal from node (spun elsewhere); returns (status, result, feedback messages)."""
    from rclpy.action import ActionClient

    client = ActionClient(node, action_type, name)
    assert client.wait_for_server(timeout_sec=30.0), f"action server {name} not available"
    feedback = []
    goal_future = client.send_goal_async(goal, feedback_callback=lambda msg: feedback.append(msg.feedback))
    handle = wait_for(lambda: goal_future.result() if goal_future.done() else None, 30.0, "goal response")
    if not handle.accepted:
        client.destroy()
        return None, None, feedback
    result_future = handle.get_result_async()
    wrapped = wait_for(lambda: result_future.result() if result_future.done() else None, timeout,
                       f"the result of {name}")
    client.destroy()
    return wrapped.status, wrapped.result, feedback
