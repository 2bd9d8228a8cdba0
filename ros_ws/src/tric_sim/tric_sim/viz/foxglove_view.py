"""A live view of the scene in Foxglove: a WebSocket server (foxglove-sdk) with the scene in 3D, the
frames, and the controller's value, step, constraints and features. ROS-free.

Imported only when a view is asked for (the visualizer node, or a tool's --viz), so that nothing of
foxglove-sdk is loaded otherwise. Channels (Foxglove's subprotocol "foxglove.sdk.v1"):
- /scene (foxglove.SceneUpdate, protobuf): the primitives of tric_sim.viz.scene_view as entities,
  each frame-locked to its frame; re-sent to every new subscriber;
- /tf (foxglove.FrameTransforms, protobuf): the frames' transforms;
- /controller/status (JSON, the fields of tric_msgs/ControllerStatus, see
  tric_sim.viz.scene_messages.status_fields): f, the step, the active constraints, the top features.
Every message is logged at its simulated time, and the server announces that time (capability
"time"), so Foxglove's clock follows the simulation, as with use_sim_time. docs/foxglove_layout.json
(foxglove_layout()) arranges these topics, and the bags' ones, in one layout.
"""

import json
import pathlib
import threading
from typing import Any

import foxglove
import foxglove.layouts as fl
from foxglove.channels import FrameTransformsChannel, SceneUpdateChannel
from foxglove.messages import (
    Color,
    CubePrimitive,
    CylinderPrimitive,
    FrameTransform,
    FrameTransforms,
    Pose,
    Quaternion,
    SceneEntity,
    SceneEntityDeletion,
    SceneEntityDeletionType,
    SceneUpdate,
    SpherePrimitive,
    Timestamp,
    Vector3,
)
from foxglove.websocket import Capability, ServerListener

SCENE_TOPIC = "/scene"
TF_TOPIC = "/tf"
STATUS_TOPIC = "/controller/status"
DEFAULT_PORT = 8765
#: JSON schema of the status channel (tric_sim.viz.scene_messages.status_fields).
_NUMBER = {"type": ["number", "null"]}
STATUS_SCHEMA = {
    "title": "tric_msgs/msg/ControllerStatus",
    "type": "object",
    "properties": {
        "stamp_ns": {"type": "integer"},
        "state": {"type": "integer"},
        "phase": {"type": "string"},
        "model_path": {"type": "string"},
        "step": {"type": "integer"},
        "value": _NUMBER,
        "value_rate": _NUMBER,
        "gradient_norm": _NUMBER,
        "step_norm": _NUMBER,
        "min_distance": _NUMBER,
        "tick_time_ms": _NUMBER,
        "active_constraints": {"type": "array", "items": {"type": "string"}},
        "feature_names": {"type": "array", "items": {"type": "string"}},
        "feature_values": {"type": "array", "items": _NUMBER},
        "feature_gradients": {"type": "array", "items": _NUMBER},
    },
}
LAYOUT_PATH = pathlib.Path("docs") / "foxglove_layout.json"


class FoxgloveView:
    """A Foxglove WebSocket server and its channels (see the module docstring).

    host: the address to listen on ("127.0.0.1": this machine only; "0.0.0.0": every interface);
    port: the TCP port (0: a free one, see .port). ValueError when the server cannot listen there.
    Thread-safe: the methods may be called from any thread."""

    def __init__(self, host: str = "127.0.0.1", port: int = DEFAULT_PORT, name: str = "tric"):
        if not 0 <= port <= 65535:
            raise ValueError(f"the Foxglove port must be in [0, 65535], got {port}")
        self._context = foxglove.Context()
        self._lock = threading.Lock()
        self._scene: SceneUpdate | None = None
        self._scene_time = 0
        self._scene_channel = SceneUpdateChannel(SCENE_TOPIC, context=self._context)
        self._tf_channel = FrameTransformsChannel(TF_TOPIC, context=self._context)
        self._status_channel = foxglove.Channel(
            STATUS_TOPIC, schema=STATUS_SCHEMA, context=self._context
        )
        try:
            self._server = foxglove.start_server(
                name=name,
                host=host,
                port=port,
                context=self._context,
                capabilities=[Capability.Time],
                server_listener=_NewSubscriber(self),
            )
        except RuntimeError as error:
            raise ValueError(
                f"the Foxglove server could not listen on {host}:{port}: {error}"
            ) from None
        self.host = host

    @property
    def port(self) -> int:
        return self._server.port

    @property
    def url(self) -> str:
        return f"ws://{self.host}:{self.port}"

    def show_scene(self, primitives, stamp_ns: int) -> None:
        """Replace the scene by these primitives (tric_sim.viz.scene_view.Primitive)."""
        update = SceneUpdate(
            deletions=[
                SceneEntityDeletion(
                    timestamp=_timestamp(stamp_ns), type=SceneEntityDeletionType.All
                )
            ],
            entities=[_entity(p, stamp_ns) for p in primitives],
        )
        with self._lock:
            self._scene, self._scene_time = update, stamp_ns
        self._scene_channel.log(update, log_time=stamp_ns)

    def show_transforms(self, transform_sets, stamp_ns: int) -> None:
        """Send the transforms (tric_sim.viz.scene_view.Transforms) stamped stamp_ns, and that
        time."""
        stamp = _timestamp(stamp_ns)
        frames = [
            FrameTransform(
                timestamp=stamp,
                parent_frame_id=parent,
                child_frame_id=child,
                translation=Vector3(x=p[0], y=p[1], z=p[2]),
                rotation=Quaternion(x=o[0], y=o[1], z=o[2], w=o[3]),
            )
            for transforms in transform_sets
            for parent, child, p, o in zip(
                transforms.parents,
                transforms.children,
                transforms.positions.tolist(),
                transforms.orientations.tolist(),
            )
        ]
        self._tf_channel.log(FrameTransforms(transforms=frames), log_time=stamp_ns)
        self._server.broadcast_time(stamp_ns)

    def show_status(self, fields: dict, stamp_ns: int) -> None:
        """Send a controller status (tric_sim.viz.scene_messages.status_fields)."""
        self._status_channel.log(fields, log_time=stamp_ns)

    def resend_scene(self) -> None:
        """Send the current scene again (for a client that subscribed after it was sent)."""
        with self._lock:
            update, stamp_ns = self._scene, self._scene_time
        if update is not None:
            self._scene_channel.log(update, log_time=stamp_ns)

    def close(self) -> None:
        self._server.stop()


class _NewSubscriber(ServerListener):
    """The server's callbacks: a new /scene subscriber gets the current scene."""

    def __init__(self, view: FoxgloveView):
        self.view = view

    def on_subscribe(self, client, channel) -> None:
        if channel.topic == SCENE_TOPIC:
            self.view.resend_scene()


def foxglove_layout() -> str:
    """docs/foxglove_layout.json: the 3D scene (live /scene and /tf, or a bag's /scene_markers and
    /tf), f and the step size over time, the top features' gradients, and the status with the
    active constraints and the features' names and values."""
    three_d = fl.ThreeDeePanel(
        config=fl.ThreeDeeConfig(
            follow_tf="world",
            topics={
                SCENE_TOPIC: fl.BaseRendererSceneUpdateTopicSettings(visible=True),
                "/scene_markers": fl.BaseRendererRosMarkerTopicSettings(visible=True),
            },
        )
    )
    value = fl.PlotPanel(
        config=fl.PlotConfig(
            paths=[
                fl.PlotSeries(value=f"{STATUS_TOPIC}.value", label="f"),
                fl.PlotSeries(
                    value=f"{STATUS_TOPIC}.step_norm", label="|dq| (rad)", y_axis_id="step"
                ),
            ],
            secondary_axes=[fl.PlotSecondaryAxis(id="step", label="step (rad)")],
        )
    )
    gradients = fl.PlotPanel(
        config=fl.PlotConfig(
            paths=[
                fl.PlotSeries(
                    value=f"{STATUS_TOPIC}.feature_gradients",
                    label="df/du of the top features",
                    array_expansion="byIndex",
                )
            ]
        )
    )
    status = fl.RawMessagesPanel(config=fl.RawMessagesConfig(topic_path=STATUS_TOPIC))
    layout = fl.Layout(
        content=fl.SplitContainer(
            direction="row",
            items=[
                fl.SplitItem(proportion=3, content=three_d),
                fl.SplitItem(
                    proportion=2,
                    content=fl.SplitContainer(
                        direction="column",
                        items=[
                            fl.SplitItem(content=value),
                            fl.SplitItem(content=gradients),
                            fl.SplitItem(content=status),
                        ],
                    ),
                ),
            ],
        )
    )
    return json.dumps(json.loads(layout.to_json()), indent=2) + "\n"


def _timestamp(stamp_ns: int) -> Timestamp:
    return Timestamp(int(stamp_ns // 1_000_000_000), int(stamp_ns % 1_000_000_000))


def _entity(primitive, stamp_ns: int) -> SceneEntity:
    x, y, z = (float(v) for v in primitive.position)
    qx, qy, qz, qw = (float(v) for v in primitive.orientation)
    sx, sy, sz = (float(v) for v in primitive.size)
    r, g, b, a = (float(v) for v in primitive.color)
    shape = {
        "box": ("cubes", CubePrimitive),
        "sphere": ("spheres", SpherePrimitive),
        "cylinder": ("cylinders", CylinderPrimitive),
    }
    field, kind = shape[primitive.shape]
    solid = kind(
        pose=Pose(position=Vector3(x=x, y=y, z=z), orientation=Quaternion(x=qx, y=qy, z=qz, w=qw)),
        size=Vector3(x=sx, y=sy, z=sz),
        color=Color(r=r, g=g, b=b, a=a),
    )
    solids: dict[str, Any] = {field: [solid]}  # e.g. cubes=[CubePrimitive]
    return SceneEntity(
        timestamp=_timestamp(stamp_ns),
        frame_id=primitive.frame,
        id=primitive.id,
        frame_locked=True,
        **solids,
    )


if __name__ == "__main__":
    LAYOUT_PATH.write_text(foxglove_layout())
    print(f"wrote {LAYOUT_PATH}")
