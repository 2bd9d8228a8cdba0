"""ROS messages of the viewer's scene (tric_sim.viz.scene_view): what RViz and foxglove_bridge show
on a stock ROS 2 install, and what the bags carry for Foxglove to replay. Imports message modules
only.

- /robot_description: std_msgs/String, the URDF (latched).
- /tf and /tf_static: tf2_msgs/TFMessage of geometry_msgs/TransformStamped (transform_msgs makes its
  elements; tf2_msgs is not on PyPI, so the pip environment has /tf in bags and over Foxglove's
  WebSocket only, see tric_sim.visualizer_node).
- /scene_markers: visualization_msgs/MarkerArray, one marker per primitive (namespace = its group,
  "robot" or "scene"), frame-locked to its frame, after a DELETEALL that clears the previous scene.
- the controller's status as plain data (status_fields), for Foxglove's JSON channels.
"""

import math

from geometry_msgs.msg import Point, Pose, Quaternion, Transform, TransformStamped, Vector3
from std_msgs.msg import ColorRGBA, String
from visualization_msgs.msg import Marker, MarkerArray

from tric_msgs.msg import ControllerStatus
from tric_sim.ros.messages import time_msg, time_ns
from tric_sim.viz.scene_view import Transforms

MARKER_TYPES = {"box": Marker.CUBE, "sphere": Marker.SPHERE, "cylinder": Marker.CYLINDER}

#: The fields of tric_msgs/ControllerStatus that status_fields copies (all but the header).
STATUS_FIELDS = (
    "state",
    "model_path",
    "step",
    "value",
    "value_rate",
    "gradient_norm",
    "step_norm",
    "min_distance",
    "active_constraints",
    "tick_time_ms",
    "feature_names",
    "feature_values",
    "feature_gradients",
)


def robot_description_msg(urdf: str) -> String:
    return String(data=urdf)


def transform_msgs(transforms: Transforms, stamp_ns: int) -> list:
    """geometry_msgs/TransformStamped of every transform, stamped stamp_ns."""
    stamp = time_msg(stamp_ns)
    out = []
    for parent, child, p, o in zip(
        transforms.parents,
        transforms.children,
        transforms.positions.tolist(),
        transforms.orientations.tolist(),
    ):
        msg = TransformStamped(
            child_frame_id=child,
            transform=Transform(
                translation=Vector3(x=p[0], y=p[1], z=p[2]),
                rotation=Quaternion(x=o[0], y=o[1], z=o[2], w=o[3]),
            ),
        )
        msg.header.stamp, msg.header.frame_id = stamp, parent
        out.append(msg)
    return out


def marker_array(primitives, stamp_ns: int) -> MarkerArray:
    """A DELETEALL marker, then one marker per primitive (ids numbered per namespace)."""
    stamp = time_msg(stamp_ns)
    markers = [Marker(action=Marker.DELETEALL)]
    numbers: dict[str, int] = {}
    for primitive in primitives:
        number = numbers[primitive.group] = numbers.get(primitive.group, -1) + 1
        x, y, z = (float(v) for v in primitive.position)
        qx, qy, qz, qw = (float(v) for v in primitive.orientation)
        sx, sy, sz = (float(v) for v in primitive.size)
        r, g, b, a = (float(v) for v in primitive.color)
        marker = Marker(
            ns=primitive.group,
            id=number,
            type=MARKER_TYPES[primitive.shape],
            action=Marker.ADD,
            pose=Pose(
                position=Point(x=x, y=y, z=z), orientation=Quaternion(x=qx, y=qy, z=qz, w=qw)
            ),
            scale=Vector3(x=sx, y=sy, z=sz),
            color=ColorRGBA(r=r, g=g, b=b, a=a),
            frame_locked=True,
        )
        marker.header.stamp, marker.header.frame_id = stamp, primitive.frame
        markers.append(marker)
    return MarkerArray(markers=markers)


#: The controller's state by name: the phase of its episode a viewer shows.
PHASES = {
    ControllerStatus.IDLE: "idle",
    ControllerStatus.RUNNING: "descending f",
    ControllerStatus.HOLDING: "holding (stale input)",
    ControllerStatus.CONVERGED: "at rest",
    ControllerStatus.GRIPPING: "at rest, gripping",
}


def status_fields(msg: ControllerStatus) -> dict:
    """A ControllerStatus as JSON-ready plain data: its fields by name (lists for arrays; NaN and
    inf, which JSON lacks, as None), "stamp_ns" and "phase" (the state by name, PHASES)."""
    fields = {name: getattr(msg, name) for name in STATUS_FIELDS}
    for name in (
        "value",
        "value_rate",
        "gradient_norm",
        "step_norm",
        "min_distance",
        "tick_time_ms",
    ):
        fields[name] = _finite_or_none(fields[name])
    for name in ("feature_values", "feature_gradients"):
        fields[name] = [_finite_or_none(v) for v in fields[name]]
    for name in ("active_constraints", "feature_names"):
        fields[name] = [str(v) for v in fields[name]]
    fields["stamp_ns"] = time_ns(msg.header.stamp)
    fields["phase"] = PHASES.get(msg.state, "unknown")
    return fields


def _finite_or_none(value):
    return float(value) if math.isfinite(value) else None
