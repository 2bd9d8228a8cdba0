"""The hidden task metrics: the teacher's world knowledge, computed from the simulator's state.

No learner reads these; they judge demonstrations and learned controllers (paper Sec. 5.3).

Grasp cost in [0, 1], lower is better, below 0.25 a good grasp. It is the mean of four terms, each
the error of a task variable a grasp expert checks, normalized to [0, 1] (1 = as bad as it gets):

- finger_contact: for each finger, |distance between its distal link and the object's surface|
  divided by FINGER_CONTACT_TOLERANCE (3 cm), clipped to 1; averaged over the fingers.
- palm_distance: how far the palm centre is from the surface beyond PALM_DISTANCE_OK (5 cm),
  divided by PALM_DISTANCE_TOLERANCE (8 cm), clipped to 1.
- palm_alignment: angle between the palm normal and the direction from the palm centre to the
  nearest surface point; (1 - cos) / (1 - cos 60 deg), clipped to 1.
- finger_opposition: do the finger contacts surround the object? The directions of the three contact
  normals are projected on the plane across the palm normal; the largest angular gap between them
  must not exceed 180 deg (otherwise the fingers all push from one side). (gap - 180) / 90 deg,
  clipped to [0, 1].

Lift test (grasps): the fingers grip (every flexion joint's target at least the robot profile's grip
squeeze past where the joint ends the episode, for GRIP_DURATION while the fixture still holds the
object), then the object is released (given its mass) and the hand raised LIFT_HEIGHT; it passes if
the object rose by at least LIFT_PASS_FRACTION of that. The grip is the evaluator's, the same for
every agent: a learned controller stops the fingers where its value function is lowest, at the
contacts' cushion, with its command equal to the measured joints, so without it the fingers hold the
object with no force. Box success: lid opened by more than 0.3 rad.

Failure class (TaskMetrics.failure, "" for a success without collision): why an episode failed,
from its final state before the lift test and the lift test's result (grasp_failure, box_failure).
Grasps, the first that holds: "collision" (even of an otherwise good grasp); "slipped in the lift
test" (a good grasp that the lift test lost); "fingers closed before the palm arrived" (the palm
farther than PALM_DISTANCE_OK from the surface, the fingers flexed more than FLEXED_MARGIN beyond
the teacher's open pre-shape); "palm off target" (the palm that far, or its palm_alignment term at
least PALM_MISALIGNED); then, the palm in place, "fingers short of the surface" when finger_contact
is the worse finger term, else "fingers on one side of the object" (finger_opposition). Boxes:
"collision"; "stalled above the lid" (both lifting fingertips above the lid's top surface, inside
its outline); "under the lip" (a lifting fingertip below the lip's level, within LIP_REACH of the
lid's outline, outside the box); else "away from the lid".
Units: m, rad.
"""

import math
from dataclasses import dataclass, field

import numpy as np
import pinocchio as pin

from tric_sim.world import scene
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.shapes import object_surface

#: The grasp cost's terms (see the module docstring): a finger's distance to the surface that
#: costs 1, m; the palm's distance that costs nothing, and the excess over it that costs 1, m; the
#: palm's misalignment that costs 1, rad.
FINGER_CONTACT_TOLERANCE = 0.03
PALM_DISTANCE_OK = 0.05
PALM_DISTANCE_TOLERANCE = 0.08
PALM_ALIGNMENT_TOLERANCE = math.radians(60)
#: A grasp is good below this cost (the paper's convention).
GOOD_GRASP = 0.25
#: A box is counted as opened when its lid angle exceeds this (Sec. 5.3.5), rad.
LID_OPEN_ANGLE = 0.3
LIFT_HEIGHT = 0.10
LIFT_DURATION = 1.0
LIFT_HOLD = 0.5
LIFT_PASS_FRACTION = 0.7
#: The lift test's grip: the finger flexion joints' targets go the robot profile's grip squeeze
#: past their final positions (clipped to the joint limits; the grasp teacher's squeeze past
#: contact), and close for GRIP_DURATION before the release (s). Chosen on the validation sets:
#: docs/decisions/lift-grip.md.
GRIP_DURATION = 0.2
#: A signed distance below this between the robot and an avoided body counts as a collision, m.
COLLISION_DISTANCE = 0.0
#: Failure classes (see the module docstring): fingers count as flexed when their flexion (proximal
#: + distal joint, rad, averaged over the fingers) exceeds the open pre-shape's by this, rad
#: (a closed sphere grasp: about 1.3 beyond it, a cylinder grasp about 1.0).
FLEXED_MARGIN = 0.3
#: A palm_alignment term at or above this is a misaligned palm (about 41 deg off the object).
PALM_MISALIGNED = 0.5
#: How far around and below the lid's outline a fingertip that lifts the lid (the robot profile's
#: lid_fingertips) counts as under its lip, m.
LIP_REACH = 0.05


@dataclass
class TaskMetrics:
    """The metrics of one final state (see tric_msgs/msg/TaskMetrics.msg)."""

    task: str
    grasp_cost: float = float("nan")
    cost_terms: dict = field(default_factory=dict)
    lift_tested: bool = False
    lift_passed: bool = False
    lift_height: float = 0.0
    lid_angle: float = float("nan")
    success: bool = False
    min_distance: float = float("nan")
    collided: bool = False
    max_joint_overshoot: float = 0.0
    overshoot_joint: str = ""
    failure: str = ""


def grasp_cost_terms(robot: RobotModel, q, kind: str, dimensions, placement: pin.SE3) -> dict:
    """The four grasp-cost terms (see the module docstring) of configuration q (n,) around an object
    of the given kind and dimensions at placement (world)."""
    robot.forward(q)
    # finger_contact: distance of each distal link (a capsule) to the surface
    profile = robot.profile
    contact_errors, contact_normals = [], []
    for link, tip in zip(profile.distal_links, profile.fingertips):
        start = robot.frame_placement(link).translation
        end = robot.frame_placement(tip).translation
        samples = start + np.linspace(0.0, 1.0, 9)[:, None] * (end - start)
        distance, normals = object_surface(kind, dimensions, placement, samples)
        k = int(np.argmin(distance))
        contact_errors.append(
            min(abs(distance[k] - profile.distal_radius) / FINGER_CONTACT_TOLERANCE, 1.0)
        )
        contact_normals.append(normals[k])
    palm = robot.frame_placement(profile.palm)
    palm_position, palm_normal = palm.translation, palm.rotation[:, 2]
    distance, normal = object_surface(kind, dimensions, placement, palm_position[None, :])
    palm_error = min(max(distance[0] - PALM_DISTANCE_OK, 0.0) / PALM_DISTANCE_TOLERANCE, 1.0)
    alignment = (1.0 - float(palm_normal @ -normal[0])) / (1.0 - math.cos(PALM_ALIGNMENT_TOLERANCE))
    # finger_opposition: the largest angular gap between the contact normals around the palm normal
    e1 = np.cross(palm_normal, [1.0, 0.0, 0.0])
    if np.linalg.norm(e1) < 1e-6:
        e1 = np.cross(palm_normal, [0.0, 1.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(palm_normal, e1)
    angles = np.sort([math.atan2(n @ e2, n @ e1) for n in contact_normals])
    gaps = np.diff(np.concatenate([angles, [angles[0] + 2 * math.pi]]))
    opposition = (math.degrees(gaps.max()) - 180.0) / 90.0
    return {
        "finger_contact": float(np.mean(contact_errors)),
        "palm_distance": float(palm_error),
        "palm_alignment": float(np.clip(alignment, 0.0, 1.0)),
        "finger_opposition": float(np.clip(opposition, 0.0, 1.0)),
    }


def finger_flexion(robot: RobotModel, q) -> float:
    """The fingers' mean flexion: the sum of a finger's flexion joint values, each signed to grow as
    the finger closes, averaged over the fingers, rad (or m)."""
    return _mean_flexion(robot.profile.fingers, dict(zip(robot.joint_names, q)))


def open_flexion(robot: RobotModel, kind: str) -> float:
    """The flexion (as finger_flexion) of the hand's open pre-shape for an object kind, rad."""
    return _mean_flexion(robot.profile.fingers, robot.profile.preshapes[kind])


def _mean_flexion(fingers, value: dict) -> float:
    """finger_flexion of the joint values value (joint -> rad or m)."""
    return float(np.mean([sum(c * value[j] for j, c in zip(f.joints, f.closing)) for f in fingers]))


def grasp_failure(
    robot: RobotModel,
    q,
    kind: str,
    terms: dict,
    collided: bool,
    lift_tested: bool,
    lift_passed: bool,
) -> str:
    """The failure class of a grasp (see the module docstring; "" for a success) from its final
    configuration q (n,) before the lift test, the object's kind, its cost terms
    (grasp_cost_terms) and the collision and lift test results."""
    if collided:
        return "collision"
    if np.mean(list(terms.values())) < GOOD_GRASP:
        return "slipped in the lift test" if lift_tested and not lift_passed else ""
    palm_far = terms["palm_distance"] > 0.0
    if palm_far and finger_flexion(robot, q) > open_flexion(robot, kind) + FLEXED_MARGIN:
        return "fingers closed before the palm arrived"
    if palm_far or terms["palm_alignment"] >= PALM_MISALIGNED:
        return "palm off target"
    if terms["finger_contact"] >= terms["finger_opposition"]:
        return "fingers short of the surface"
    return "fingers on one side of the object"


def box_failure(
    robot: RobotModel, q, side: float, object_poses: dict, lid_angle: float, collided: bool
) -> str:
    """The failure class of a box opening (see the module docstring; "" for a success) from its
    final configuration q (n,), the box's side (m), the object poses ("object": the box body,
    "lid_edge": the lip; name -> (position, xyzw)), the lid angle and whether the robot collided."""
    if collided:
        return "collision"
    if lid_angle > LID_OPEN_ANGLE:
        return ""
    robot.forward(q)
    tips = np.array(
        [robot.frame_placement(tip).translation for tip in robot.profile.lid_fingertips]
    )
    lip = scene.se3(*object_poses["lid_edge"])
    # in the lip's frame: x towards the free edge
    local = (tips - lip.translation) @ lip.rotation
    depth, width, thickness = scene.lid_extents(side)
    inside_outline = (
        (local[:, 0] >= -depth) & (local[:, 0] <= 0.0) & (np.abs(local[:, 1]) <= width / 2)
    )
    if np.all(inside_outline & (local[:, 2] > thickness)):
        return "stalled above the lid"
    body = scene.se3(*object_poses["object"])
    in_box = np.all(np.abs((tips - body.translation) @ body.rotation) <= side / 2, axis=1)
    near_lip = (
        (local[:, 0] >= -depth)
        & (local[:, 0] <= LIP_REACH)
        & (np.abs(local[:, 1]) <= width / 2 + LIP_REACH)
        & (local[:, 2] >= -LIP_REACH)
    )
    if np.any(near_lip & (local[:, 2] < 0.0) & ~in_box):
        return "under the lip"
    return "away from the lid"


def lift_test(world, robot: RobotModel) -> float:
    """Grip (the profile's grip squeeze over GRIP_DURATION), release the object and raise the hand
    LIFT_HEIGHT over LIFT_DURATION, then hold LIFT_HOLD; returns how far the object rose, m.
    Changes the world (reset it afterwards)."""
    q, _ = world.joint_state()
    start_height = world.object_poses()["object"][0][2]
    robot.forward(q)
    palm = robot.frame_placement(robot.profile.palm)
    raised = pin.SE3(palm.rotation, palm.translation + np.array([0.0, 0.0, LIFT_HEIGHT]))
    q_raised = robot.reach(q, robot.profile.palm, raised)
    hand_targets = world.targets.copy()
    flexion = np.array([robot.joint_names.index(j) for j in robot.profile.flexion_joints])
    gripped = robot.closed(q[flexion], flexion, robot.profile.grip_squeeze)
    closing = robot.closing_signs[flexion] > 0
    targets = hand_targets[flexion]
    hand_targets[flexion] = np.where(
        closing, np.maximum(targets, gripped), np.minimum(targets, gripped)
    )
    world.command(hand_targets)
    for _ in range(int(round(GRIP_DURATION / world.control_period))):
        world.step()
    world.release_object()
    periods = int(round(LIFT_DURATION / world.control_period))
    for k in range(1, periods + int(round(LIFT_HOLD / world.control_period)) + 1):
        fraction = min(k / periods, 1.0)
        target = hand_targets.copy()
        target[robot.arm_indices] = (1 - fraction) * q[robot.arm_indices] + fraction * q_raised[
            robot.arm_indices
        ]
        world.command(target)
        world.step()
    return float(world.object_poses()["object"][0][2] - start_height)


def evaluate(world, robot: RobotModel, run_lift_test: bool = False) -> TaskMetrics:
    """The metrics of the world's current state (and of the lift test, if asked and a grasp)."""
    situation = world.situation
    if situation is None:
        raise ValueError("no scene: reset the simulator to a situation first")
    metrics = TaskMetrics(task=situation.task, min_distance=float(world.min_distance))
    metrics.collided = metrics.min_distance < COLLISION_DISTANCE
    q, _ = world.joint_state()
    if situation.task == "open_box":
        metrics.lid_angle = world.lid_angle()
        metrics.success = metrics.lid_angle > LID_OPEN_ANGLE
        metrics.failure = box_failure(
            robot,
            q,
            situation.object_dimensions[0],
            world.object_poses(),
            metrics.lid_angle,
            metrics.collided,
        )
        return _with_overshoot(metrics, world)
    position, orientation = world.object_poses()["object"]
    terms = grasp_cost_terms(
        robot,
        q,
        situation.object_kind,
        situation.object_dimensions,
        scene.se3(position, orientation),
    )
    metrics.cost_terms = terms
    metrics.grasp_cost = float(np.mean(list(terms.values())))
    metrics.success = metrics.grasp_cost < GOOD_GRASP
    if run_lift_test:
        metrics.lift_tested = True
        metrics.lift_height = lift_test(world, robot)
        metrics.lift_passed = metrics.lift_height >= LIFT_PASS_FRACTION * LIFT_HEIGHT
        metrics.success = metrics.success and metrics.lift_passed
    metrics.failure = grasp_failure(
        robot,
        q,
        situation.object_kind,
        terms,
        metrics.collided,
        metrics.lift_tested,
        metrics.lift_passed,
    )
    return _with_overshoot(metrics, world)


def _with_overshoot(metrics: TaskMetrics, world) -> TaskMetrics:
    """metrics with the largest joint-limit overshoot measured since the scene's reset (lift test
    included)."""
    metrics.max_joint_overshoot = float(world.stops.max_overshoot)
    metrics.overshoot_joint = world.stops.max_overshoot_joint
    return metrics
