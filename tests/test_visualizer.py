"""The live views: a real WebSocket client on `tric-eval --viz` while a short lockstep episode runs,
the visualizer node's ROS topics against the situation's geometry, and `ros2 run tric_sim
visualizer` alone (a one-line refusal of a bad port; its end on SIGINT and SIGTERM is
tested with every node's in test_interrupts)."""

import asyncio
import base64
import json
import math
import pathlib
import socket
import struct
import subprocess
import threading

import numpy as np
import pytest
import websockets
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from std_msgs.msg import String
from visualization_msgs.msg import Marker, MarkerArray

from conftest import HANG_S, call, wait_for
from tric_control import evaluate_cli
from tric_control.top_features import TOP_FEATURES
from tric_learning import bags, model_file
from tric_learning.recording import record_offline
from tric_learning.training.value import TrainingConfig, train
from tric_msgs.srv import ResetScene
from tric_sim.ros import messages
from tric_sim.simulator_node import SimulatorNode
from tric_sim.visualizer_node import VisualizerNode
from tric_sim.viz import scene_view
from tric_sim.viz.foxglove_view import FoxgloveView
from tric_sim.world import scene, situations
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation_files import save_situations

LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
SUBPROTOCOL = "foxglove.sdk.v1"
VISUALIZER = (
    pathlib.Path(__file__).resolve().parent.parent
    / "ros_ws/install/tric_sim/lib/tric_sim/visualizer"
)


@pytest.fixture(scope="module")
def model_path(tmp_path_factory):
    """A tiny TRIC grasp model (3 demonstrations, 5 hidden units): fast to make, not meant to
    grasp."""
    robot = RobotModel()
    dataset = record_offline(robot, situations.sphere_grid()[12:15], 5.0)
    result = train(
        dataset, robot, TrainingConfig(hidden_units=5, noisy_samples=10, max_iterations=20)
    )
    return str(
        model_file.from_training(result, dataset).save(
            tmp_path_factory.mktemp("model") / "model.safetensors"
        )
    )


# --- reading Foxglove's protobuf messages without a protobuf library --------------------------


def protobuf_fields(data: bytes) -> list:
    """[(field number, value)] of a protobuf message: ints for varints, bytes for length-delimited
    fields (nested messages, strings), raw bytes for fixed-width ones."""
    fields, k = [], 0

    def varint():
        nonlocal k
        value, shift = 0, 0
        while True:
            byte = data[k]
            k += 1
            value |= (byte & 0x7F) << shift
            shift += 7
            if byte < 0x80:
                return value

    while k < len(data):
        key = varint()
        number, wire = key >> 3, key & 7
        if wire == 0:
            fields.append((number, varint()))
        elif wire == 2:
            size = varint()
            fields.append((number, data[k : k + size]))
            k += size
        else:
            size = 8 if wire == 1 else 4
            fields.append((number, data[k : k + size]))
            k += size
    return fields


def field_numbers(descriptor_set: bytes) -> dict:
    """{message name: {field name: number}} of a FileDescriptorSet (as Foxglove advertises schemas):
    FileDescriptorSet.file = 1; FileDescriptorProto.message_type = 4; DescriptorProto.name = 1,
    .field = 2; FieldDescriptorProto.name = 1, .number = 3."""
    numbers = {}
    for number, file in protobuf_fields(descriptor_set):
        for kind, message in protobuf_fields(file):
            if number == 1 and kind == 4:
                parts = protobuf_fields(message)
                name = next(v for n, v in parts if n == 1).decode()
                numbers[name] = {}
                for n, field in parts:
                    if n == 2:
                        entries = dict(protobuf_fields(field))
                        numbers[name][entries[1].decode()] = entries[3]
    return numbers


def decode(data: bytes, numbers: dict, message: str) -> dict:
    """{field name: [raw values]} of a message named in numbers."""
    names = {number: name for name, number in numbers[message].items()}
    out = {}
    for number, value in protobuf_fields(data):
        out.setdefault(names.get(number), []).append(value)
    return out


# --- the live view of tric-eval --------------------------------------------------------------


def free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


async def watch(port: int, serving: threading.Event, views: list) -> dict:
    """Once serving is set (the tool's Foxglove server listens, or the tool ended: views empty),
    connect, subscribe to every channel and collect everything until the tool stops its server:
    {"info": serverInfo, "channels": {topic: advertisement}, "messages": {topic: [(log time,
    payload)]}, "times": [ns]}."""
    seen = {"info": None, "channels": {}, "messages": {}, "times": []}
    started = await asyncio.get_running_loop().run_in_executor(None, serving.wait, HANG_S)
    assert started, "the tool neither started its server nor ended"
    if not views:
        return seen
    connection = await websockets.connect(
        f"ws://127.0.0.1:{port}", subprotocols=[SUBPROTOCOL], max_size=None
    )
    by_subscription = {}
    async with connection:
        assert connection.subprotocol == SUBPROTOCOL
        while True:
            try:
                frame = await asyncio.wait_for(connection.recv(), HANG_S)
            except websockets.ConnectionClosed:  # the tool is done and has stopped its server
                break
            if isinstance(frame, str):
                message = json.loads(frame)
                if message["op"] == "serverInfo":
                    seen["info"] = message
                elif message["op"] == "advertise":
                    subscriptions = []
                    for channel in message["channels"]:
                        seen["channels"][channel["topic"]] = channel
                        by_subscription[len(by_subscription)] = channel["topic"]
                        subscriptions.append(
                            {"id": len(by_subscription) - 1, "channelId": channel["id"]}
                        )
                    await connection.send(
                        json.dumps({"op": "subscribe", "subscriptions": subscriptions})
                    )
            elif frame[0] == 0x01:  # message data: subscription id, log time, payload
                subscription, log_time = struct.unpack_from("<IQ", frame, 1)
                seen["messages"].setdefault(by_subscription[subscription], []).append(
                    (log_time, frame[13:])
                )
            elif frame[0] == 0x02:  # the server's time
                seen["times"].append(struct.unpack_from("<Q", frame, 1)[0])
    return seen


def test_tric_eval_viz_serves_the_episode_live(model_path, tmp_path, monkeypatch):
    """`tric-eval --viz --record DIR` on one sphere: a Foxglove client gets the server's info and
    the channels, then the scene of the situation, the frames as the robot moves, the value f, the
    step and the top features of every few ticks; the recorded bag has the status of every tick."""
    situation = situations.dataset("sphere_test")[2]
    situations_file = tmp_path / "one.yaml"
    save_situations(situations_file, [situation])
    port = free_port()
    serving, views, exit_codes = threading.Event(), [], []
    listen = FoxgloveView.__init__

    def listen_and_tell(view, *args, **kwargs):
        listen(view, *args, **kwargs)
        views.append(view)
        serving.set()

    monkeypatch.setattr(FoxgloveView, "__init__", listen_and_tell)

    def run_tool():
        try:
            exit_codes.append(
                evaluate_cli.main(
                    [
                        "--model",
                        model_path,
                        "--situations-file",
                        str(situations_file),
                        "--max-steps",
                        "150",
                        "--viz",
                        "--viz-port",
                        str(port),
                        "--record",
                        str(tmp_path / "bags"),
                    ]
                )
            )
        finally:
            serving.set()

    tool = threading.Thread(target=run_tool)
    tool.start()
    try:
        seen = asyncio.run(watch(port, serving, views))
    finally:
        tool.join()
    assert exit_codes == [0]

    assert seen["info"]["capabilities"] == ["time"]
    channels = seen["channels"]
    assert channels["/scene"]["schemaName"] == "foxglove.SceneUpdate"
    assert channels["/tf"]["schemaName"] == "foxglove.FrameTransforms"
    assert channels["/controller/status"]["encoding"] == "json"
    numbers = {}
    for topic in ("/scene", "/tf"):
        assert (
            channels[topic]["encoding"] == "protobuf"
            and channels[topic]["schemaEncoding"] == "protobuf"
        )
        numbers.update(field_numbers(base64.b64decode(channels[topic]["schema"])))

    # the scene: the robot's 21 collision primitives and the situation's table and sphere,
    # frame-locked
    scenes = [decode(payload, numbers, "SceneUpdate") for _, payload in seen["messages"]["/scene"]]
    entities = {}
    for entity in (decode(e, numbers, "SceneEntity") for e in scenes[-1]["entities"]):
        entities[entity["id"][0].decode()] = entity
    expected = scene_view.RobotView(RobotModel()).primitives + scene_view.scene_primitives(
        situation
    )
    assert sorted(entities) == sorted(p.id for p in expected)
    for primitive in expected:
        entity = entities[primitive.id]
        assert entity["frame_id"][0].decode() == primitive.frame and entity["frame_locked"] == [1]
    sphere = decode(entities["scene/object"]["spheres"][0], numbers, "SpherePrimitive")
    size = decode(sphere["size"][0], numbers, "Vector3")
    assert struct.unpack("<d", size["x"][0])[0] == pytest.approx(2 * situation.object_dimensions[0])

    # the frames, as the robot moves, at simulated times the server also announces
    frames = seen["messages"]["/tf"]
    assert len(frames) >= 3
    children = {
        decode(t, numbers, "FrameTransform")["child_frame_id"][0].decode()
        for t in decode(frames[-1][1], numbers, "FrameTransforms")["transforms"]
    }
    assert {"base_link", "palm_center", "finger_1_tip", "object"} <= children
    assert seen["times"] and max(seen["times"]) == max(t for t, _ in frames)

    # f, the step and the top features, during the episode
    statuses = [json.loads(payload) for _, payload in seen["messages"]["/controller/status"]]
    assert len(statuses) >= 3
    steps = [s["step"] for s in statuses]
    assert steps == sorted(steps) and steps[-1] <= 150 and len(set(steps)) >= 3
    for status in statuses:
        assert math.isfinite(status["value"]) and status["step_norm"] >= 0
        assert (
            len(status["feature_names"])
            == len(status["feature_values"])
            == len(status["feature_gradients"])
            == TOP_FEATURES
        )
        assert isinstance(status["active_constraints"], list)

    # the episode's bag: the status of every tick, the outcome, the scene topics
    [bag] = sorted((tmp_path / "bags").glob("*.mcap"))
    info = bags.bag_info(bag)
    status_count = info.topics["/controller/status"].message_count
    assert status_count >= max(steps)
    assert "tric.outcome" in info.custom_data and info.custom_data["tric.source"] == "tric"
    assert {"/tf", "/tf_static", "/robot_description", "/scene_markers"} <= set(info.topics)
    recorded = [m.message for m in bags.read_bag(bag, topics=["/controller/status"])]
    assert [m.step for m in recorded] == list(range(1, status_count + 1))
    assert recorded[0].feature_names == statuses[0]["feature_names"]


def test_the_layout_in_docs_is_the_generated_one():
    from tric_sim.viz.foxglove_view import LAYOUT_PATH, foxglove_layout

    path = pathlib.Path(__file__).resolve().parent.parent / LAYOUT_PATH
    assert path.read_text() == foxglove_layout(), (
        "regenerate it: python -m tric_sim.viz.foxglove_view"
    )
    panels = json.dumps(json.loads(path.read_text()))
    for topic in (
        "/scene",
        "/scene_markers",
        "/controller/status.value",
        "/controller/status.feature_gradients",
    ):
        assert f'"{topic}' in panels


# --- the visualizer node's ROS topics --------------------------------------------------------


class Viewer(Node):
    """What RViz would subscribe to."""

    def __init__(self, context):
        super().__init__("test_viewer", context=context)
        self.descriptions, self.markers = [], []
        self.create_subscription(String, "/robot_description", self.descriptions.append, LATCHED)
        self.create_subscription(MarkerArray, "/scene_markers", self.markers.append, LATCHED)


def test_visualizer_publishes_the_description_and_the_scene_markers(ros_context, spin):
    simulator = SimulatorNode(context=ros_context)
    visualizer = VisualizerNode(
        context=ros_context, parameter_overrides=[Parameter("foxglove", value=False)]
    )
    viewer = spin(simulator, visualizer, Viewer(ros_context))[2]
    situation = situations.find_situation("sphere_test_01_obstacle")
    reset = call(
        viewer,
        ResetScene,
        "/simulator/reset_scene",
        ResetScene.Request(situation=messages.situation_to_msg(situation)),
    )
    assert reset.success, reset.message
    wait_for(lambda: viewer.descriptions, what="/robot_description")
    assert viewer.descriptions[0].data == RobotModel().urdf_path.read_text()

    def scene_markers():
        latest = viewer.markers[-1].markers if viewer.markers else []
        return [
            m for m in latest if m.ns == "scene" and m.header.frame_id == "obstacle_0"
        ] and latest

    markers = wait_for(scene_markers, what="the obstacle situation's markers")
    assert markers[0].action == Marker.DELETEALL
    by_frame = {m.header.frame_id: m for m in markers if m.ns == "scene"}
    assert sorted(by_frame) == ["object", "obstacle_0", "world"]
    obstacle = situation.obstacles[0]
    plate = by_frame["obstacle_0"]
    assert plate.type == Marker.CUBE and plate.frame_locked
    assert (plate.scale.x, plate.scale.y, plate.scale.z) == pytest.approx(obstacle.dimensions)
    table = by_frame["world"]
    assert (table.pose.position.x, table.pose.position.y, table.pose.position.z) == pytest.approx(
        scene.TABLE_POSITION
    )
    assert (table.scale.x, table.scale.y, table.scale.z) == pytest.approx(scene.TABLE_SIZE)
    sphere = by_frame["object"]
    assert sphere.type == Marker.SPHERE and sphere.scale.x == pytest.approx(
        2 * situation.object_dimensions[0]
    )
    robot = [m for m in markers if m.ns == "robot"]
    assert len(robot) == 21 and len({m.id for m in robot}) == 21
    assert {m.header.frame_id for m in robot} >= {"base_link", "palm_link", "finger_3_distal_link"}
    assert np.isclose(visualizer.situation.object_position, situation.object_position).all()


# --- ros2 run tric_sim visualizer ----------------------------------------------------------


def test_visualizer_refuses_a_bad_port_in_one_line():
    result = subprocess.run(
        [str(VISUALIZER), "--ros-args", "-p", "foxglove_port:=70000"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2
    assert result.stderr.strip().splitlines() == [
        "visualizer: parameter foxglove_port must be in [0, 65535], got 70000"
    ]
