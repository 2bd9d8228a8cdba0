"""Sample messages of every field kind, the bag they make, and a deep comparison of a message with
what a reader decoded, for the bag tests."""

import array
import math

import numpy as np
import yaml
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Point32, Polygon, Pose, Quaternion
from mcap.reader import make_reader
from sensor_msgs.msg import Image, Imu, JointState
from shape_msgs.msg import SolidPrimitive
from std_msgs.msg import (
    Byte,
    ByteMultiArray,
    Empty,
    Header,
    MultiArrayDimension,
    MultiArrayLayout,
    UInt16MultiArray,
)

from tric_learning import bags
from tric_msgs.msg import EpisodeEvent, FeatureSample, ObjectPoses, Situation, TaskMetrics

NAN = float("nan")


def pose(x, y, z, qw=1.0):
    return Pose(position=Point(x=x, y=y, z=z), orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=qw))


def situation_msg():
    box = SolidPrimitive(type=SolidPrimitive.BOX, dimensions=[0.1, 0.2, 0.3])
    cylinder = SolidPrimitive(type=SolidPrimitive.CYLINDER, dimensions=[0.5, 0.05])
    prism = SolidPrimitive(
        type=SolidPrimitive.PRISM,
        dimensions=[0.25],
        polygon=Polygon(points=[Point32(x=0.5, y=-0.25, z=0.0), Point32(x=1.5)]),
    )
    return Situation(
        name="sphere_grid_07",
        task="grasp",
        object_kind="sphere",
        object_dimensions=[0.04],
        object_pose=pose(0.5, 0.1, 0.8),
        obstacles=[box, cylinder, prism],
        obstacle_poses=[
            pose(0.3, -0.2, 0.9),
            pose(0.6, 0.3, 0.85, qw=-1.0),
            pose(0.0, 0.0, 0.0),
        ],
        initial_joint_positions=[],
        seed=7,
    )


def feature_sample(step, n_joints=7, n_features=12):
    rng = np.random.default_rng(step)
    jacobian = rng.normal(size=n_features * n_joints)
    jacobian[3] = NAN
    return FeatureSample(
        header=Header(stamp=Time(sec=12, nanosec=500_000_000 + step), frame_id="world"),
        step=step,
        fingerprint="f" * 64,
        q=rng.uniform(-1, 1, n_joints).tolist(),
        y=[NAN, math.inf, -0.0] + rng.normal(size=n_features - 3).tolist(),
        jacobian_rows=n_features,
        jacobian_cols=n_joints,
        jacobian=jacobian.tolist(),
        objects=ObjectPoses(
            header=Header(frame_id="world"),
            names=["object", "lid"],
            poses=[pose(0.5, 0.0, 0.8), pose(0.5, 0.1, 0.9, qw=0.5)],
        ),
    )


def sample_messages():
    """(topic, message, stamp in ns) of every kind the module must round-trip, in write order."""
    pairs = UInt16MultiArray(
        layout=MultiArrayLayout(dim=[MultiArrayDimension(label="pairs", size=2)]),
        data=[0, 1, 65535, 7],
    )
    metrics = TaskMetrics(
        task="grasp",
        grasp_cost=NAN,
        cost_term_names=["x"],
        cost_term_values=[0.25],
        lift_tested=True,
        lift_passed=False,
        lift_height=0.0,
        lid_angle=NAN,
        success=False,
        min_distance=-0.001,
        collided=True,
    )
    empty_sample = feature_sample(9)
    empty_sample.q, empty_sample.y, empty_sample.jacobian = [], [], []
    empty_sample.objects = ObjectPoses()
    imu = Imu()
    imu.orientation_covariance[:] = np.arange(9.0)
    imu.orientation_covariance[4] = NAN
    layout = MultiArrayLayout(
        dim=[
            MultiArrayDimension(label="rows", size=2, stride=4),
            MultiArrayDimension(label="cols", size=2, stride=2),
        ],
        data_offset=1,
    )
    return [
        ("/pairs", pairs, 1_000),
        (
            "/joint_states",
            JointState(
                header=Header(stamp=Time(sec=1, nanosec=2), frame_id="base"),
                name=["arm_1", "arm_2", "finger_1"],
                position=[0.5, -1.25, NAN],
                velocity=[],
                effort=[1e-300, -1e300, 0.0],
            ),
            2_000,
        ),
        ("/samples", feature_sample(0), 3_000),
        ("/samples", feature_sample(1), 4_000),
        ("/situation", situation_msg(), 5_000),
        (
            "/episode",
            EpisodeEvent(
                header=Header(frame_id="world"),
                event=EpisodeEvent.OUTCOME,
                episode_id="sphere_grid_07",
                source="teacher",
                situation=situation_msg(),
                metrics=metrics,
            ),
            6_000,
        ),
        ("/samples", empty_sample, 7_000),
        (
            "/image",
            Image(height=1, width=5, encoding="mono8", step=5, data=bytes([0, 1, 2, 255, 0])),
            8_000,
        ),
        ("/bytes", ByteMultiArray(layout=layout, data=[b"\x00", b"\x7f", b"\x07"]), 9_000),
        ("/imu", imu, 10_000),
        ("/empty", Empty(), 11_000),
        ("/byte", Byte(data=b"\x7f"), 12_000),
        ("/joint_states", JointState(name=["arm_1"], position=[2.0]), 13_000),
    ]


LATCHED = {"/pairs", "/situation"}


CUSTOM_DATA = {"episode_id": "sphere_grid_07", "fingerprint": "f" * 64}


def write_bag(path, messages, flush_every=True, custom_data=CUSTOM_DATA):
    with bags.BagWriter(path, custom_data=custom_data) as writer:
        for topic, message_class in {t: type(m) for t, m, _ in messages}.items():
            writer.add_topic(topic, message_class, latched=topic in LATCHED)
        for topic, message, stamp in messages:
            writer.write(topic, message, stamp)
            if flush_every:
                writer.flush()
    return writer.path


def items(value):
    """The items of an array as written (rclpy) or decoded (lists, bytes, numpy arrays)."""
    if isinstance(value, (bytes, bytearray)):
        return list(value)
    return [v[0] if isinstance(v, bytes) else v for v in value]


def assert_same(expected, actual, where="message"):
    """actual (decoded by any reader) holds the same fields and values as the rclpy message
    expected."""
    if hasattr(type(expected), "get_fields_and_field_types"):
        for name in type(expected).get_fields_and_field_types():
            assert_same(getattr(expected, name), getattr(actual, name), f"{where}.{name}")
    elif isinstance(expected, (list, tuple, array.array, np.ndarray)) or (
        # rclpy: byte = b'x'
        isinstance(expected, bytes) and not isinstance(actual, (int, np.integer))
    ):
        expected_items, actual_items = items(expected), items(actual)
        assert len(expected_items) == len(actual_items), where
        for i, (e, a) in enumerate(zip(expected_items, actual_items)):
            assert_same(e, a, f"{where}[{i}]")
    else:
        expected = expected[0] if isinstance(expected, bytes) else expected
        actual = actual.item() if isinstance(actual, np.generic) else actual
        if isinstance(expected, float) and math.isnan(expected):
            assert math.isnan(actual), where
        else:
            assert expected == actual, f"{where}: {expected!r} != {actual!r}"


def rosbag2_metadata(path):
    with open(path, "rb") as file:
        return [
            yaml.safe_load(m.metadata["serialized_metadata"])
            for m in make_reader(file).iter_metadata()
            if m.name == "rosbag2"
        ]
