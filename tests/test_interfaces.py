"""Every tric_msgs message, service and action crosses DDS intact between two nodes in one
process."""

import importlib
import math
import threading

import numpy as np
import pytest
from rclpy.action import ActionClient, ActionServer
from rclpy.node import Node
from rclpy.task import Future

import tric_msgs.action
import tric_msgs.msg
import tric_msgs.srv
from conftest import HANG_S

MESSAGES = [
    "ObjectPoses",
    "Situation",
    "FeatureDefinition",
    "FeatureSample",
    "TaskMetrics",
    "EpisodeEvent",
    "ControllerStatus",
    "TrainingProgress",
]
SERVICES = ["ResetScene", "EvaluateTask", "RenderScene", "Train", "LoadModel"]
ACTIONS = ["Demonstrate", "Execute"]
RR = ("Request", "Response")
GFR = ("Goal", "Feedback", "Result")


def filled(msg_class, seed=1):
    """An instance of msg_class with every field set to a non-default value derived from seed."""
    msg = msg_class()
    for name, type_name in msg_class.get_fields_and_field_types().items():
        setattr(msg, name, _value(type_name, seed + len(name)))
    return msg


def _value(type_name, seed):
    if type_name.startswith("sequence<"):
        inner = type_name[len("sequence<") : -1].split(",")[0]
        return [_value(inner, seed + k) for k in range(2)]
    if "[" in type_name:  # fixed-size array, e.g. double[36]
        inner, size = type_name[:-1].split("[")
        return [_value(inner, seed + k) for k in range(int(size))]
    if type_name in ("string", "wstring") or type_name.startswith("string<"):
        return f"value-{seed}"
    if type_name == "boolean":
        return True  # the only value that is not the default
    if type_name in ("float", "double"):
        return seed + 0.25
    if type_name in ("octet", "char", "uint8", "byte"):
        return seed % 200 + 1 if type_name != "octet" else bytes([seed % 200 + 1])
    if "/" in type_name:  # nested message, e.g. geometry_msgs/Pose
        package, name = type_name.split("/")
        return filled(getattr(importlib.import_module(package + ".msg"), name), seed)
    if "int" in type_name:
        return seed % 100 + 1
    raise AssertionError(f"unhandled field type {type_name}")


def as_dict(value):
    """A message as nested plain Python values, for equality checks."""
    if hasattr(value, "get_fields_and_field_types"):
        return {name: as_dict(getattr(value, name)) for name in value.get_fields_and_field_types()}
    if isinstance(value, (list, tuple, np.ndarray)) or type(value).__name__ == "array":
        return [as_dict(v) for v in value]
    return value


def defaults_left(value, where="msg"):
    """The fields of a message (nested ones, and the elements of arrays, included) that hold their
    type's default: False, 0, 0.0, "", b"\\x00" or an empty array."""
    if hasattr(value, "get_fields_and_field_types"):
        return [
            path
            for name in value.get_fields_and_field_types()
            for path in defaults_left(getattr(value, name), f"{where}.{name}")
        ]
    if isinstance(value, (list, tuple, np.ndarray)) or type(value).__name__ == "array":
        if len(value) == 0:
            return [where]
        return [path for k, v in enumerate(value) for path in defaults_left(v, f"{where}[{k}]")]
    return [where] if value in (False, b"\x00", "") or value == type(value)() else []


@pytest.mark.parametrize("seed", [1, 2, 3, 7, 100])
def test_filled_messages_set_every_field_to_a_non_default(seed):
    interfaces = [getattr(tric_msgs.msg, name) for name in MESSAGES]
    interfaces += [getattr(getattr(tric_msgs.srv, n), part) for n in SERVICES for part in RR]
    interfaces += [getattr(getattr(tric_msgs.action, n), part) for n in ACTIONS for part in GFR]
    for cls in interfaces:
        assert defaults_left(filled(cls, seed)) == [], cls.__name__
    assert defaults_left(tric_msgs.msg.TaskMetrics(lift_tested=True)) != []  # it can fail


@pytest.mark.parametrize("name", MESSAGES)
def test_message_round_trip(spin, ros_context, name):
    cls = getattr(tric_msgs.msg, name)
    sent = filled(cls)
    talker = Node("talker", context=ros_context)
    listener = Node("listener", context=ros_context)
    received, got = [], threading.Event()
    listener.create_subscription(cls, "/roundtrip", lambda m: (received.append(m), got.set()), 10)
    publisher = talker.create_publisher(cls, "/roundtrip", 10)
    talker.create_timer(0.05, lambda: publisher.publish(sent))
    spin(talker, listener)
    assert got.wait(HANG_S), "timed out waiting for the round trip"
    assert as_dict(received[0]) == as_dict(sent)


@pytest.mark.parametrize("name", SERVICES)
def test_service_round_trip(spin, ros_context, name):
    srv = getattr(tric_msgs.srv, name)
    request, response = filled(srv.Request, 3), filled(srv.Response, 7)
    server = Node("server", context=ros_context)
    client_node = Node("client", context=ros_context)
    seen = []

    def handle(req, resp):
        seen.append(req)
        return response

    server.create_service(srv, "/echo", handle)
    client = client_node.create_client(srv, "/echo")
    spin(server, client_node)
    assert client.wait_for_service(timeout_sec=HANG_S)
    result = client.call(request, timeout_sec=HANG_S)
    assert as_dict(seen[0]) == as_dict(request)
    assert as_dict(result) == as_dict(response)


@pytest.mark.parametrize("name", ACTIONS)
def test_action_round_trip(spin, ros_context, name):
    """Goal, feedback and result cross intact; the server succeeds only once the client has its
    feedback, so exactly one feedback message must arrive."""
    action = getattr(tric_msgs.action, name)
    goal, feedback, result = (
        filled(action.Goal, 2),
        filled(action.Feedback, 4),
        filled(action.Result, 6),
    )
    server = Node("action_server", context=ros_context)
    client_node = Node("action_client", context=ros_context)
    seen_goals, feedbacks, feedback_seen = [], [], Future()

    async def execute(goal_handle):
        seen_goals.append(goal_handle.request)
        goal_handle.publish_feedback(feedback)
        # the executor spins on (the client's feedback callback) meanwhile
        await feedback_seen
        goal_handle.succeed()
        return result

    def on_feedback(message):
        feedbacks.append(message.feedback)
        if not feedback_seen.done():
            feedback_seen.set_result(True)

    ActionServer(server, action, "/echo_action", execute)
    client = ActionClient(client_node, action, "/echo_action")
    spin(server, client_node)
    assert client.wait_for_server(timeout_sec=HANG_S)
    done = threading.Event()
    outcome = {}

    def on_result(future):
        outcome["result"] = future.result().result
        done.set()

    def on_goal(future):
        handle = future.result()
        assert handle.accepted
        handle.get_result_async().add_done_callback(on_result)

    client.send_goal_async(goal, feedback_callback=on_feedback).add_done_callback(on_goal)
    assert done.wait(HANG_S)
    assert as_dict(seen_goals[0]) == as_dict(goal)
    assert as_dict(outcome["result"]) == as_dict(result)
    assert len(feedbacks) == 1 and as_dict(feedbacks[0]) == as_dict(feedback)


def test_nan_inf_and_negative_zero_survive_the_wire(spin, ros_context):
    """TaskMetrics uses NaN for "not applicable": it crosses DDS as NaN, as do inf and -0.0."""
    sent = tric_msgs.msg.TaskMetrics(
        task="grasp",
        grasp_cost=math.nan,
        lid_angle=math.inf,
        min_distance=-0.0,
        cost_term_names=["a", "b"],
        cost_term_values=[math.nan, -math.inf],
    )
    talker = Node("talker", context=ros_context)
    listener = Node("listener", context=ros_context)
    received, got = [], threading.Event()
    listener.create_subscription(
        tric_msgs.msg.TaskMetrics,
        "/metrics_roundtrip",
        lambda m: (received.append(m), got.set()),
        10,
    )
    publisher = talker.create_publisher(tric_msgs.msg.TaskMetrics, "/metrics_roundtrip", 10)
    talker.create_timer(0.05, lambda: publisher.publish(sent))
    spin(talker, listener)
    assert got.wait(HANG_S), "timed out waiting for the round trip"
    metrics = received[0]
    assert metrics.task == "grasp"
    assert math.isnan(metrics.grasp_cost) and metrics.lid_angle == math.inf
    assert metrics.min_distance == 0.0 and math.copysign(1.0, metrics.min_distance) == -1.0
    assert math.isnan(metrics.cost_term_values[0]) and metrics.cost_term_values[1] == -math.inf
