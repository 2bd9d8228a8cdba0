"""The grasp teacher (GraspTeacher): a phased reactive grasp controller in the spirit of Dragiev et
al. (2011), the paper's sphere and cylinder teacher. Each phase servos its own task variables
through differential inverse kinematics on the shared Pinocchio model (tric_sim.teachers.pose_servo:
a small QP with joint limits, velocity limits and a table-clearance constraint):

1. reach: pre-shape the hand and bring the palm to a pre-grasp pose (the robot profile's
   grasp_teacher.pregrasp_distance) before the object, along an approach direction chosen from the
   object's position (tric_sim.teachers.grasp_approach);
2. approach: move the palm along that direction to the grasp pose (the palm centre the profile's
   grasp_gap from the surface);
3. close: flex the fingers (at the profile's closing_speed) until each touches the object, then
   squeeze.

Units: m, rad, s.
"""

import numpy as np
import pinocchio as pin

from tric_sim.teachers.grasp_approach import approach_direction, cylinder_grasp_point, frame_from
from tric_sim.teachers.pose_servo import PoseServo
from tric_sim.world import scene
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.shapes import object_surface
from tric_sim.world.situation import Situation

#: Phase tolerances: palm position (m) and orientation (rad) error to leave reach / approach.
REACH_TOLERANCE = (0.015, 0.08)
APPROACH_TOLERANCE = (0.004, 0.04)
#: Finger closing: contact distance (m); the targets then go the robot profile's grip squeeze past
#: contact (rad). A proximal link's radius, m.
CONTACT_DISTANCE = 0.002
PROXIMAL_RADIUS = 0.016
#: The reference may lead the measured arm joints by at most this (rad); when the arm is held back
#: (contact), the reference is pulled back so the teacher stays reactive.
MAX_REFERENCE_LEAD = 0.1


class GraspTeacher:
    """The phased grasp teacher for a sphere or cylinder situation (see the module docstring).

    command(elapsed_s, q, poses) is called once per control period with the time since the start,
    the measured joint positions (n,) and the objects' world poses ({name: (position, xyzw)}); it
    returns the joint position targets (n,).
    """

    planning_time_s = 0.0

    def __init__(self, robot: RobotModel, situation: Situation, period: float = 0.01):
        if situation.task != "grasp":
            raise ValueError(
                f"GraspTeacher grasps spheres and cylinders, not task '{situation.task}'"
            )
        self.robot, self.situation, self.period = robot, situation, period
        self.kind = situation.object_kind
        self.servo = PoseServo(robot, period)
        self.phase = "reach"
        self.reference: np.ndarray | None = None
        index = robot.joint_names.index
        self.preshape = {index(j): angle for j, angle in robot.profile.preshapes[self.kind].items()}
        self.fingers = [[index(j) for j in finger.joints] for finger in robot.profile.fingers]
        self.finger_state = ["closing" if joints else "squeezing" for joints in self.fingers]
        self.grasp_pose: pin.SE3 | None = None
        self.settings = robot.profile.grasp_teacher

    # --- poses ---------------------------------------------------------------------------------

    def _poses(self, object_pose, q: np.ndarray):
        """Grasp and pre-grasp palm poses for the object at object_pose. The palm's roll about its
        approach axis is free for a sphere (and two-fold for a cylinder): the teacher takes the one
        whose inverse-kinematics solution stays nearest the home posture, within the joint
        limits."""
        centre = np.asarray(object_pose[0], dtype=float)
        placement = scene.se3(*object_pose)
        if self.kind == "cylinder":
            height, radius = self.situation.object_dimensions
            axis = placement.rotation[:, 2]
            centre, n = cylinder_grasp_point(centre, axis, height, self.settings)
            # palm y along the axis (fingers 2 and 3 side by side along it): x = y cross z
            rotations = [np.column_stack([np.cross(y, n), y, n]) for y in (axis, -axis)]
        else:
            radius = self.situation.object_dimensions[0]
            n = approach_direction(centre, self.settings)
            base = frame_from(n, np.array([0.0, 0.0, -1.0]))
            rotations = [base @ pin.utils.rotate("z", a) for a in np.radians(np.arange(0, 360, 30))]
        position = centre - n * (radius + self.settings.grasp_gap[self.kind])
        grasp = min(
            (pin.SE3(rotation, position) for rotation in rotations),
            key=lambda pose: self._posture_cost(q, pose),
        )
        pregrasp = pin.SE3(
            grasp.rotation, grasp.translation - n * self.settings.pregrasp_distance[self.kind]
        )
        return grasp, pregrasp

    def _posture_cost(self, q: np.ndarray, pose: pin.SE3) -> float:
        """Distance from home of the IK solution for pose, plus penalties for an unreached pose or a
        joint near its limit."""
        robot, arm = self.robot, self.robot.arm_indices
        solution = robot.reach(q, robot.profile.palm, pose, iterations=150)
        robot.forward(solution)
        error = np.linalg.norm(
            pin.log6(robot.frame_placement(robot.profile.palm).actInv(pose)).vector
        )
        margin = np.min(
            np.minimum(solution[arm] - robot.lower[arm], robot.upper[arm] - solution[arm])
        )
        return (
            float(np.linalg.norm(solution[arm] - robot.home[arm]))
            + 10.0 * error
            + 10.0 * max(0.0, 0.2 - margin)
        )

    # --- control -------------------------------------------------------------------------------

    def command(self, elapsed_s: float, q: np.ndarray, poses: dict) -> np.ndarray:
        object_pose = poses["object"]
        q = np.asarray(q, dtype=float)
        if self.reference is None:
            self.reference = q.copy()
            grasp, pregrasp = self._poses(object_pose, q)
            self.grasp_pose, self.pregrasp_pose = grasp, pregrasp
        reference = self.reference
        arm = self.robot.arm_indices
        lead = reference[arm] - q[arm]
        reference[arm] = q[arm] + np.clip(lead, -MAX_REFERENCE_LEAD, MAX_REFERENCE_LEAD)
        if self.phase in ("reach", "approach"):
            target = self.pregrasp_pose if self.phase == "reach" else self.grasp_pose
            avoid = None
            if self.phase == "reach":
                avoid = (self.kind, self.situation.object_dimensions, scene.se3(*object_pose))
            reference[arm] += self.servo.step(reference, target, avoid)
            self._preshape(reference)
            self.robot.forward(reference)
            error = self.robot.frame_placement(self.robot.profile.palm).actInv(target)
            position_error = np.linalg.norm(error.translation)
            angle_error = np.linalg.norm(pin.log3(error.rotation))
            tolerance = REACH_TOLERANCE if self.phase == "reach" else APPROACH_TOLERANCE
            if (
                position_error < tolerance[0]
                and angle_error < tolerance[1]
                and self._preshaped(reference)
            ):
                self.phase = "approach" if self.phase == "reach" else "close"
        else:
            self._close(reference, object_pose)
        return self.robot.check_configuration(
            np.clip(reference, self.robot.lower, self.robot.upper)
        )

    def _preshape(self, reference):
        goal = reference.copy()
        for joint, angle in self.preshape.items():
            goal[joint] = angle
        hand = self.robot.hand_indices
        step = self.robot.velocity_limits[hand] * self.period * 0.9
        reference[hand] += np.clip(goal[hand] - reference[hand], -step, step)

    def _preshaped(self, reference) -> bool:
        return all(abs(reference[joint] - angle) < 1e-3 for joint, angle in self.preshape.items())

    def _close(self, reference, object_pose):
        """Flex each finger (its joints together, each in its closing direction) until its distal
        link touches, then squeeze; the first joint stops once its own link touches. A finger a
        mimic joint moves has nothing to flex (it squeezes from the start)."""
        placement = scene.se3(*object_pose)
        dims = self.situation.object_dimensions
        robot, profile = self.robot, self.robot.profile
        robot.forward(reference)
        step = self.settings.closing_speed * self.period
        for k, (finger, joints) in enumerate(zip(profile.fingers, self.fingers)):
            if self.finger_state[k] != "closing":
                continue
            last = joints[-1]
            distal = self._link_distance(
                finger.links[-1], finger.tip, placement, dims, profile.distal_radius
            )
            proximal = self._link_distance(
                finger.links[0], finger.links[-1], placement, dims, PROXIMAL_RADIUS
            )
            sign = robot.closing_signs[last]
            limit = robot.upper[last] if sign > 0 else robot.lower[last]
            closed = sign * reference[last] >= sign * limit - self.settings.closing_margin
            if distal <= CONTACT_DISTANCE or closed:
                reference[joints] = robot.closed(reference[joints], joints, profile.grip_squeeze)
                self.finger_state[k] = "squeezing"
                continue
            moving = joints if proximal > CONTACT_DISTANCE else joints[1:]
            reference[moving] = robot.closed(reference[moving], moving, step)
        if all(state == "squeezing" for state in self.finger_state):
            self.phase = "hold"

    def _link_distance(self, start_frame, end_frame, placement, dims, radius) -> float:
        start = self.robot.frame_placement(start_frame).translation
        end = self.robot.frame_placement(end_frame).translation
        samples = start + np.linspace(0.0, 1.0, 9)[:, None] * (end - start)
        distance, _ = object_surface(self.kind, dims, placement, samples)
        return float(distance.min() - radius)
