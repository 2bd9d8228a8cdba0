"""Conversions between tric_sim's plain data and ROS messages (tric_msgs and standard types).

Used by the nodes of every package; imports message modules only (no rclpy).
"""

import math

import numpy as np
from builtin_interfaces.msg import Time
from geometry_msgs.msg import Point, Pose, Quaternion
from sensor_msgs.msg import JointState
from shape_msgs.msg import SolidPrimitive

from tric_msgs.msg import ObjectPoses
from tric_msgs.msg import Perturbation as PerturbationMsg
from tric_msgs.msg import Situation as SituationMsg
from tric_msgs.msg import TaskMetrics as TaskMetricsMsg
from tric_sim.world.perturbations import Perturbation
from tric_sim.world.situation import Obstacle, Situation, check_name

SHAPE_TYPES = {
    "box": SolidPrimitive.BOX,
    "sphere": SolidPrimitive.SPHERE,
    "cylinder": SolidPrimitive.CYLINDER,
}
SHAPE_NAMES = {v: k for k, v in SHAPE_TYPES.items()}


def time_msg(nanoseconds: int) -> Time:
    return Time(sec=int(nanoseconds // 1_000_000_000), nanosec=int(nanoseconds % 1_000_000_000))


def time_ns(stamp: Time) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def pose_msg(position, orientation) -> Pose:
    x, y, z, w = (float(v) for v in orientation)
    return Pose(
        position=Point(x=float(position[0]), y=float(position[1]), z=float(position[2])),
        orientation=Quaternion(x=x, y=y, z=z, w=w),
    )


def pose_tuple(pose: Pose) -> tuple:
    """(position, xyzw) of a geometry_msgs/Pose."""
    p, q = pose.position, pose.orientation
    return (p.x, p.y, p.z), (q.x, q.y, q.z, q.w)


def situation_to_msg(situation: Situation) -> SituationMsg:
    msg = SituationMsg(
        name=situation.name,
        task=situation.task,
        object_kind=situation.object_kind,
        object_dimensions=[float(v) for v in situation.object_dimensions],
        object_pose=pose_msg(situation.object_position, situation.object_orientation),
        initial_joint_positions=[float(v) for v in situation.initial_joint_positions],
        seed=int(situation.seed),
        perturbations=[perturbation_msg(p) for p in situation.perturbations],
    )
    for obstacle in situation.obstacles:
        # SolidPrimitive's box dimensions are the full extents; cylinder (height, radius); sphere
        # (r).
        msg.obstacles.append(
            SolidPrimitive(
                type=SHAPE_TYPES[obstacle.shape], dimensions=[float(v) for v in obstacle.dimensions]
            )
        )
        msg.obstacle_poses.append(pose_msg(obstacle.position, obstacle.orientation))
    return msg


def situation_from_msg(msg: SituationMsg, n_joints: int = 14) -> Situation:
    """A validated Situation from its message, or ValueError saying what is wrong."""
    check_name(msg.name)  # before it is quoted
    if len(msg.obstacles) != len(msg.obstacle_poses):
        raise ValueError(
            f"situation '{msg.name}': {len(msg.obstacles)} obstacles but "
            f"{len(msg.obstacle_poses)} obstacle poses"
        )
    obstacles = []
    for k, (shape, pose) in enumerate(zip(msg.obstacles, msg.obstacle_poses)):
        if shape.type not in SHAPE_NAMES:
            raise ValueError(
                f"situation '{msg.name}': obstacle {k} has unsupported primitive type "
                f"{shape.type} (box, sphere or cylinder)"
            )
        position, orientation = pose_tuple(pose)
        obstacles.append(
            Obstacle(
                SHAPE_NAMES[shape.type],
                tuple(float(v) for v in shape.dimensions),
                position,
                orientation,
            )
        )
    position, orientation = pose_tuple(msg.object_pose)
    return Situation(
        name=msg.name,
        task=msg.task,
        object_kind=msg.object_kind,
        object_dimensions=tuple(float(v) for v in msg.object_dimensions),
        object_position=position,
        object_orientation=orientation,
        obstacles=tuple(obstacles),
        initial_joint_positions=tuple(float(v) for v in msg.initial_joint_positions),
        seed=int(msg.seed),
        # a bag recorded before situations had perturbations decodes without the field
        perturbations=tuple(perturbation_from_msg(p) for p in getattr(msg, "perturbations", ())),
    ).validate(n_joints)


def perturbation_msg(perturbation: Perturbation) -> PerturbationMsg:
    return PerturbationMsg(
        kind=perturbation.kind,
        start_s=float(perturbation.start_s),
        duration_s=float(perturbation.duration_s),
        offset=[float(v) for v in perturbation.offset],
    )


def perturbation_from_msg(msg: PerturbationMsg) -> Perturbation:
    """The plain perturbation of a message (validated by the situation or service that takes it)."""
    return Perturbation(
        kind=msg.kind,
        start_s=float(msg.start_s),
        offset=tuple(float(v) for v in msg.offset),
        duration_s=float(msg.duration_s),
    )


def object_poses_msg(poses: dict, stamp_ns: int) -> ObjectPoses:
    msg = ObjectPoses()
    msg.header.stamp = time_msg(stamp_ns)
    msg.header.frame_id = "world"
    for name, (position, orientation) in poses.items():
        msg.names.append(name)
        msg.poses.append(pose_msg(position, orientation))
    return msg


def object_poses_from_msg(msg: ObjectPoses) -> dict:
    """name -> (position, xyzw) from an ObjectPoses message, or ValueError if malformed."""
    if len(msg.names) != len(msg.poses):
        raise ValueError(f"ObjectPoses has {len(msg.names)} names but {len(msg.poses)} poses")
    poses = {}
    for name, pose in zip(msg.names, msg.poses):
        position, orientation = pose_tuple(pose)
        values = np.array(position + orientation)
        if not np.all(np.isfinite(values)):
            raise ValueError(f"ObjectPoses: the pose of '{name}' has non-finite values")
        poses[name] = (position, orientation)
    return poses


def joint_state_msg(names, positions, velocities, stamp_ns: int) -> JointState:
    msg = JointState(
        name=list(names),
        position=[float(v) for v in positions],
        velocity=[float(v) for v in velocities],
    )
    msg.header.stamp = time_msg(stamp_ns)
    return msg


def joint_positions_from_msg(msg: JointState, joint_names) -> np.ndarray:
    """Positions (n,) in the order of joint_names from a JointState holding all of them, or
    ValueError if a joint is missing, sizes differ or values are not finite."""
    if len(msg.name) != len(msg.position):
        raise ValueError(f"JointState has {len(msg.name)} names but {len(msg.position)} positions")
    index = {name: i for i, name in enumerate(msg.name)}
    missing = [name for name in joint_names if name not in index]
    if missing:
        raise ValueError(f"JointState lacks joint(s) {', '.join(missing)}")
    q = np.array([msg.position[index[name]] for name in joint_names])
    if not np.all(np.isfinite(q)):
        raise ValueError("JointState has non-finite positions")
    return q


def metrics_msg(metrics) -> TaskMetricsMsg:
    """A TaskMetrics message from tric_sim.physics.metrics.TaskMetrics."""
    return TaskMetricsMsg(
        task=metrics.task,
        grasp_cost=float(metrics.grasp_cost),
        cost_term_names=list(metrics.cost_terms),
        cost_term_values=[float(v) for v in metrics.cost_terms.values()],
        lift_tested=bool(metrics.lift_tested),
        lift_passed=bool(metrics.lift_passed),
        lift_height=float(metrics.lift_height),
        lid_angle=float(metrics.lid_angle),
        success=bool(metrics.success),
        min_distance=float(metrics.min_distance),
        collided=bool(metrics.collided),
        max_joint_overshoot=float(metrics.max_joint_overshoot),
        overshoot_joint=metrics.overshoot_joint,
        failure=metrics.failure,
    )


#: Fields added to messages after bags were recorded with them ("pkg/Type" -> names, last fields of
#: the type): a bag whose definition lacks them is read without them (metrics_dict).
LATER_FIELDS = {
    "tric_msgs/TaskMetrics": ("max_joint_overshoot", "overshoot_joint", "failure"),
    "tric_msgs/Situation": ("perturbations",),
    # a type whose every field is optional may be missing from a bag's definition altogether
    "tric_msgs/Perturbation": ("kind", "start_s", "duration_s", "offset"),
}


def metrics_dict(msg: TaskMetricsMsg) -> dict:
    """Plain data of a TaskMetrics message (for JSON files and bags' metadata)."""
    return {
        "task": msg.task,
        "grasp_cost": _finite_or_none(msg.grasp_cost),
        "cost_terms": dict(zip(msg.cost_term_names, (float(v) for v in msg.cost_term_values))),
        "lift_tested": msg.lift_tested,
        "lift_passed": msg.lift_passed,
        "lift_height": float(msg.lift_height),
        "lid_angle": _finite_or_none(msg.lid_angle),
        "success": msg.success,
        "min_distance": float(msg.min_distance),
        "collided": msg.collided,
        # bags recorded before these fields existed decode without them: unknown, not zero
        "max_joint_overshoot": _finite_or_none(
            float(getattr(msg, "max_joint_overshoot", math.nan))
        ),
        "overshoot_joint": getattr(msg, "overshoot_joint", ""),
        "failure": getattr(msg, "failure", None),
    }


def _finite_or_none(value: float):
    return None if math.isnan(value) else float(value)
