"""Conversions between tric_learning's plain data and its messages (FeatureDefinition,
FeatureSample). Message modules only, no rclpy. Also reads the same messages as decoded from bags
(objects with the same attribute names)."""

import numpy as np

from tric_learning.features import FeatureDefinition
from tric_msgs.msg import FeatureDefinition as FeatureDefinitionMsg
from tric_msgs.msg import FeatureSample
from tric_sim.ros import messages


def definition_msg(definition: FeatureDefinition) -> FeatureDefinitionMsg:
    return FeatureDefinitionMsg(
        task=definition.task,
        landmark_names=list(definition.landmark_names),
        landmark_sources=list(definition.landmark_sources),
        pair_from=[int(i) for i, _ in definition.pairs],
        pair_to=[int(j) for _, j in definition.pairs],
        feature_names=list(definition.feature_names),
        joint_names=list(definition.joint_names),
        robot_model=definition.robot_model,
        fingerprint=definition.fingerprint,
    )


def definition_from_msg(msg) -> FeatureDefinition:
    """The definition in a FeatureDefinition message, or ValueError if it is inconsistent."""
    if len(msg.pair_from) != len(msg.pair_to):
        raise ValueError("FeatureDefinition: pair_from and pair_to differ in length")
    definition = FeatureDefinition.from_dict(
        {
            "task": msg.task,
            "landmark_names": list(msg.landmark_names),
            "landmark_sources": list(msg.landmark_sources),
            "pairs": [[int(i), int(j)] for i, j in zip(msg.pair_from, msg.pair_to)],
            "joint_names": list(msg.joint_names),
            "robot_model": msg.robot_model,
        }
    )
    if definition.fingerprint != msg.fingerprint:
        raise ValueError("FeatureDefinition: the fingerprint does not match its content")
    if tuple(msg.feature_names) != definition.feature_names:
        raise ValueError("FeatureDefinition: the feature names do not match its pairs")
    return definition


def sample_msg(sample, fingerprint: str) -> FeatureSample:
    """A FeatureSample message of a tric_learning.recording.Sample."""
    rows, cols = sample.jacobian.shape
    msg = FeatureSample(
        step=int(sample.step),
        fingerprint=fingerprint,
        q=sample.q.tolist(),
        y=sample.y.tolist(),
        jacobian_rows=rows,
        jacobian_cols=cols,
        jacobian=sample.jacobian.reshape(-1).tolist(),
        objects=messages.object_poses_msg(sample.object_poses, sample.stamp_ns),
    )
    msg.header.stamp = messages.time_msg(sample.stamp_ns)
    msg.header.frame_id = "world"
    return msg


def sample_arrays(msg, definition: FeatureDefinition):
    """(stamp_ns, q (n,), y (d,), jacobian (d, n), object poses) of a FeatureSample, or ValueError
    if it does not fit the definition or holds non-finite values."""
    n, d = len(definition.joint_names), definition.size
    if msg.fingerprint != definition.fingerprint:
        raise ValueError("a sample of another feature definition")
    q, y, jacobian = (np.asarray(v, dtype=float) for v in (msg.q, msg.y, msg.jacobian))
    if (
        q.shape != (n,)
        or y.shape != (d,)
        or (msg.jacobian_rows, msg.jacobian_cols) != (d, n)
        or jacobian.shape != (d * n,)
    ):
        raise ValueError(
            f"a sample with sizes q {q.shape}, y {y.shape}, jacobian "
            f"{msg.jacobian_rows} x {msg.jacobian_cols}; expected {n}, {d}, {d} x {n}"
        )
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(y)) and np.all(np.isfinite(jacobian))):
        raise ValueError("a sample with non-finite values")
    poses = messages.object_poses_from_msg(msg.objects)
    return messages.time_ns(msg.header.stamp), q, y, jacobian.reshape(d, n), poses
