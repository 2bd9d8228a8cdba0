"""The teachers: expert controllers that know the task and the world, and whose motions TRIC
watches.

GraspTeacher is a phased reactive grasp controller in the spirit of Dragiev et al. (2011), the
paper's sphere and cylinder teacher: each phase servos its own task variables through differential
inverse kinematics on the shared Pinocchio model (a small QP with joint limits, velocity limits and
a table-clearance constraint):

1. reach: pre-shape the hand and bring the palm to a pre-grasp pose PREGRASP_DISTANCE before the
   object, along an approach direction chosen from the object's position;
2. approach: move the palm along that direction to the grasp pose;
3. close: flex the fingers until each touches the object, then squeeze.

BoxTeacher (see box_teacher.py) plans the box opening. Teachers are ROS-free: each control period
they map the time, the measured joint positions and the objects' poses to joint position targets.
Units: m, rad, s.
"""

import math

import numpy as np
import pinocchio as pin
import proxsuite

from tric_sim import metrics, scene
from tric_sim.box_teacher import BoxTeacher
from tric_sim.robot_model import FINGERTIPS, PALM, RobotModel
from tric_sim.situation import Situation

#: The shoulder (arm_2 joint) in the world frame at any arm_1 angle, m.
SHOULDER = np.array([0.0, 0.0, 0.30])
#: Distance from the palm centre back to the wrist (arm_6 joint), m.
PALM_TO_WRIST = 0.19
#: The approach tilt is chosen so that the wrist ends this far from the shoulder: a comfortable,
#: well-conditioned elbow angle across the workspace, m.
COMFORTABLE_WRIST_DISTANCE = 0.55
#: Palm-centre distance to the object's surface at the grasp and at the pre-grasp pose, m.
GRASP_GAP = {"sphere": 0.025, "cylinder": 0.035}
PREGRASP_DISTANCE = {"sphere": 0.10, "cylinder": 0.14}
#: Hand pre-shapes: (knuckle, proximal, distal) in rad. Spheres: the three fingers spread at 120
#: degrees; cylinders: fingers 2 and 3 side by side, facing the thumb, opened wide enough that the
#: proximal links clear the cylinder until the palm is in place (see
#: docs/decisions/cylinder-teacher.md).
PRESHAPE = {"sphere": (math.pi / 3, -0.45, 0.35), "cylinder": (0.0, -0.9, 0.6)}
#: The palm pose servo descends the pose error E = |dx|^2 + ORIENTATION_LENGTH^2 |drot|^2 (m^2)
#: along its joint-space gradient, with steps that make E fall at SERVO_RATE (1/s): exponentially,
#: as long as the joints' velocity limits allow.
SERVO_RATE = 6.0
ORIENTATION_LENGTH = 0.3
#: Phase tolerances: palm position (m) and orientation (rad) error to leave reach / approach.
REACH_TOLERANCE = (0.015, 0.08)
APPROACH_TOLERANCE = (0.004, 0.04)
#: Finger closing: joint speed (rad/s), contact distance (m), and how far past contact the targets
#: go to squeeze (rad).
CLOSING_SPEED = 1.5
CONTACT_DISTANCE = 0.002
SQUEEZE = 0.12
#: Points kept at least TABLE_CLEARANCE above the table top (z = 0), m.
TABLE_CLEARANCE = 0.03
CLEARANCE_FRAMES = (PALM, *FINGERTIPS)
#: While reaching, these hand points keep OBJECT_CLEARANCE (m, beyond their own radius) from the
#: object, so that the hand goes around it to the pre-grasp pose.
HAND_POINTS = (
    (PALM, 0.0),
    ("finger_1_tip", 0.014),
    ("finger_2_tip", 0.014),
    ("finger_3_tip", 0.014),
    ("finger_1_distal_link", 0.016),
    ("finger_2_distal_link", 0.016),
    ("finger_3_distal_link", 0.016),
    ("palm_link", 0.06),
)
OBJECT_CLEARANCE = 0.015
#: Velocity-damper rate: the fraction of the remaining margin a point may close per period.
DAMPER_RATE = 0.5
#: The reference may lead the measured arm joints by at most this (rad); when the arm is held back
#: (contact), the reference is pulled back so the teacher stays reactive.
MAX_REFERENCE_LEAD = 0.1
FINGER_JOINTS = (
    ("finger_1_proximal_joint", "finger_1_distal_joint"),
    ("finger_2_proximal_joint", "finger_2_distal_joint"),
    ("finger_3_proximal_joint", "finger_3_distal_joint"),
)
PROXIMAL_LINKS = ("finger_1_proximal_link", "finger_2_proximal_link", "finger_3_proximal_link")


def _wrist_discomfort(point: np.ndarray, n: np.ndarray) -> float:
    """How far the wrist would be from COMFORTABLE_WRIST_DISTANCE to the shoulder, m, when the palm
    approaches point along n."""
    wrist = point - n * (0.06 + PALM_TO_WRIST)
    return abs(float(np.linalg.norm(wrist - SHOULDER)) - COMFORTABLE_WRIST_DISTANCE)


def approach_direction(centre: np.ndarray) -> np.ndarray:
    """Unit vector along which the palm approaches a sphere centred at centre (world): pointing away
    from the robot in azimuth, tilted down so the wrist ends COMFORTABLE_WRIST_DISTANCE from the
    shoulder."""
    azimuth = math.atan2(centre[1], centre[0])
    candidates = [
        np.array([math.cos(t) * math.cos(azimuth), math.cos(t) * math.sin(azimuth), -math.sin(t)])
        for t in np.radians(np.arange(10.0, 81.0, 1.0))
    ]
    return min(candidates, key=lambda n: _wrist_discomfort(centre, n))


#: A cylinder's approach from the robot's left (+y) costs this much more per unit of y, m: an
#: upright cylinder in front of the robot has two mirror approaches of equal comfort, and the
#: demonstrations should not flip between them (docs/decisions/cylinder-teacher.md).
SIDE_PREFERENCE = 0.02


def cylinder_grasp_point(centre: np.ndarray, axis: np.ndarray, height: float):
    """(point on the axis, approach direction across the axis) for a cylinder: the direction points
    away from the robot and not upwards, the point lies within the middle of the cylinder, and the
    pair puts the wrist closest to COMFORTABLE_WRIST_DISTANCE from the shoulder. A cylinder whose
    axis points at the robot has no direction across it that points away: then the direction may
    point across (down onto the cylinder, or sideways)."""
    e1 = np.cross(axis, [0.0, 0.0, 1.0])
    if np.linalg.norm(e1) < 1e-6:
        e1 = np.cross(axis, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    outward = np.array([centre[0], centre[1], 0.0]) / np.linalg.norm(centre[:2])
    best, best_cost = None, math.inf
    for least_outward in (0.2, -0.2):
        for offset in np.linspace(-0.3, 0.3, 7) * height:
            point = centre + offset * axis
            for angle in np.radians(np.arange(0.0, 360.0, 5.0)):
                n = math.cos(angle) * e1 + math.sin(angle) * e2
                if n @ outward < least_outward or n[2] > 0.1:
                    continue
                cost = (
                    _wrist_discomfort(point, n)
                    + 0.05 * abs(offset) / height
                    + SIDE_PREFERENCE * max(float(n[1]), 0.0)
                )
                if cost < best_cost:
                    best, best_cost = (point, n), cost
        if best is not None:
            return best
    raise ValueError("no direction across the cylinder's axis points away from the robot or down")


def frame_from(normal: np.ndarray, x_hint: np.ndarray) -> np.ndarray:
    """Rotation with z = normal and x as close to x_hint as possible (orthogonalized)."""
    z = normal / np.linalg.norm(normal)
    x = x_hint - (x_hint @ z) * z
    if np.linalg.norm(x) < 1e-6:
        x = np.cross(z, [0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])


class PoseServo:
    """The arm's motion towards a palm pose: each call returns joint increments (7,) along the
    steepest descent of the pose error in joint space, at bounded speed, within joint limits, above
    the table and (while reaching) clear of the object. Moving down a gradient in joint space is
    what TRIC assumes of a teacher (paper Sec. 3.2.3 and Proposition 1)."""

    def __init__(self, robot: RobotModel, period: float):
        self.robot, self.period = robot, period
        self.palm = robot.frame_id(PALM)
        self.clearance_frames = [robot.frame_id(f) for f in CLEARANCE_FRAMES]
        self.hand_points = [(robot.frame_id(f), radius) for f, radius in HAND_POINTS]
        n = len(robot.arm_indices)
        self.qp = proxsuite.proxqp.dense.QP(
            n, 0, len(self.clearance_frames) + len(self.hand_points), True
        )
        self.qp.settings.eps_abs = 1e-7
        self.qp.settings.max_iter = 200  # an infeasible step (conflicting dampers) returns its best
        self.qp.settings.verbose = False
        self.initialized = False

    def step(self, q: np.ndarray, target: pin.SE3, avoid=None) -> np.ndarray:
        """Joint increments of the arm (7,) towards target; avoid = (kind, dimensions, placement) of
        an object the hand must keep OBJECT_CLEARANCE from, or None."""
        robot, arm = self.robot, self.robot.arm_indices
        robot.forward(q)
        pin.computeJointJacobians(robot.model, robot.data, q)
        current = robot.data.oMf[self.palm]
        position_error = target.translation - current.translation
        rotation_error = pin.log3(target.rotation @ current.rotation.T)  # world frame
        jac = pin.getFrameJacobian(robot.model, robot.data, self.palm, pin.LOCAL_WORLD_ALIGNED)[
            :, arm
        ]
        # steepest descent of the weighted pose error in joint space (transpose-Jacobian control),
        # its speed capped by the joints' velocity limits
        error = np.concatenate([position_error, ORIENTATION_LENGTH**2 * rotation_error])
        cost = (
            position_error @ position_error
            + ORIENTATION_LENGTH**2 * rotation_error @ rotation_error
        )
        descent = jac.T @ error  # -1/2 of the gradient of the cost
        # step length: the cost falls by SERVO_RATE * period of itself (to first order)
        desired = descent * (SERVO_RATE * self.period * cost / max(2.0 * descent @ descent, 1e-18))
        max_step = robot.velocity_limits[arm] * self.period * 0.9
        desired *= min(1.0, float(np.min(max_step / np.maximum(np.abs(desired), 1e-12))))
        hessian = np.eye(len(arm))
        gradient = -desired
        rows, lower = [], []
        for fid in self.clearance_frames:
            z = robot.data.oMf[fid].translation[2]
            rows.append(
                pin.getFrameJacobian(robot.model, robot.data, fid, pin.LOCAL_WORLD_ALIGNED)[2, arm]
            )
            # velocity damper: approach the floor gradually
            lower.append(0.5 * (TABLE_CLEARANCE - z))
        for fid, radius in self.hand_points:
            jac_point = pin.getFrameJacobian(robot.model, robot.data, fid, pin.LOCAL_WORLD_ALIGNED)[
                :3, arm
            ]
            if avoid is None:
                rows.append(np.zeros(len(arm)))
                lower.append(-1e20)
                continue
            distance, normal = metrics.object_surface(
                avoid[0], avoid[1], avoid[2], robot.data.oMf[fid].translation[None, :]
            )
            rows.append(normal[0] @ jac_point)
            lower.append(DAMPER_RATE * (OBJECT_CLEARANCE - (distance[0] - radius)))
        rows, lower = np.array(rows), np.array(lower)
        upper = np.full(len(lower), 1e20)
        box_low = np.maximum(robot.lower[arm] + 0.02 - q[arm], -max_step)
        box_high = np.minimum(robot.upper[arm] - 0.02 - q[arm], max_step)
        box_low = np.minimum(box_low, 0.0)
        box_high = np.maximum(box_high, 0.0)
        if self.initialized:
            self.qp.update(
                H=hessian, g=gradient, C=rows, l=lower, u=upper, l_box=box_low, u_box=box_high
            )
        else:
            self.qp.init(hessian, gradient, None, None, rows, lower, upper, box_low, box_high)
            self.initialized = True
        self.qp.solve()
        return np.clip(self.qp.results.x, box_low, box_high)


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
        self.reference = None
        self.knuckle = robot.joint_names.index("finger_2_knuckle_joint")
        self.fingers = [[robot.joint_names.index(j) for j in pair] for pair in FINGER_JOINTS]
        self.finger_state = ["closing"] * 3
        self.grasp_pose = None

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
            centre, n = cylinder_grasp_point(centre, axis, height)
            # palm y along the axis (fingers 2 and 3 side by side along it): x = y cross z
            rotations = [np.column_stack([np.cross(y, n), y, n]) for y in (axis, -axis)]
        else:
            radius = self.situation.object_dimensions[0]
            n = approach_direction(centre)
            base = frame_from(n, np.array([0.0, 0.0, -1.0]))
            rotations = [base @ pin.utils.rotate("z", a) for a in np.radians(np.arange(0, 360, 30))]
        position = centre - n * (radius + GRASP_GAP[self.kind])
        grasp = min(
            (pin.SE3(rotation, position) for rotation in rotations),
            key=lambda pose: self._posture_cost(q, pose),
        )
        pregrasp = pin.SE3(grasp.rotation, grasp.translation - n * PREGRASP_DISTANCE[self.kind])
        return grasp, pregrasp

    def _posture_cost(self, q: np.ndarray, pose: pin.SE3) -> float:
        """Distance from home of the IK solution for pose, plus penalties for an unreached pose or a
        joint near its limit."""
        robot, arm = self.robot, self.robot.arm_indices
        solution = robot.reach(q, PALM, pose, iterations=150)
        robot.forward(solution)
        error = np.linalg.norm(pin.log6(robot.frame_placement(PALM).actInv(pose)).vector)
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
            error = self.robot.frame_placement(PALM).actInv(target)
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
        knuckle, proximal, distal = PRESHAPE[self.kind]
        goal = reference.copy()
        goal[self.knuckle] = knuckle
        for prox, dist in self.fingers:
            goal[prox], goal[dist] = proximal, distal
        hand = self.robot.hand_indices
        step = self.robot.velocity_limits[hand] * self.period * 0.9
        reference[hand] += np.clip(goal[hand] - reference[hand], -step, step)

    def _preshaped(self, reference) -> bool:
        knuckle, proximal, _ = PRESHAPE[self.kind]
        return abs(reference[self.knuckle] - knuckle) < 1e-3 and all(
            abs(reference[prox] - proximal) < 1e-3 for prox, _ in self.fingers
        )

    def _close(self, reference, object_pose):
        """Flex each finger (proximal and distal together) until its links touch, then squeeze."""
        placement = scene.se3(*object_pose)
        dims = self.situation.object_dimensions
        self.robot.forward(reference)
        step = CLOSING_SPEED * self.period
        for k, (prox, dist) in enumerate(self.fingers):
            if self.finger_state[k] != "closing":
                continue
            distal = self._link_distance(
                metrics.DISTAL_LINKS[k], FINGERTIPS[k], placement, dims, metrics.DISTAL_RADIUS
            )
            proximal = self._link_distance(
                PROXIMAL_LINKS[k], metrics.DISTAL_LINKS[k], placement, dims, 0.016
            )
            if distal <= CONTACT_DISTANCE or reference[dist] >= self.robot.upper[dist] - 0.05:
                reference[prox] = min(reference[prox] + SQUEEZE, self.robot.upper[prox])
                reference[dist] = min(reference[dist] + SQUEEZE, self.robot.upper[dist])
                self.finger_state[k] = "squeezing"
                continue
            if proximal > CONTACT_DISTANCE:
                reference[prox] = min(reference[prox] + step, self.robot.upper[prox])
            reference[dist] = min(reference[dist] + step, self.robot.upper[dist])
        if all(state == "squeezing" for state in self.finger_state):
            self.phase = "hold"

    def _link_distance(self, start_frame, end_frame, placement, dims, radius) -> float:
        start = self.robot.frame_placement(start_frame).translation
        end = self.robot.frame_placement(end_frame).translation
        samples = start + np.linspace(0.0, 1.0, 9)[:, None] * (end - start)
        distance, _ = metrics.object_surface(self.kind, dims, placement, samples)
        return float(distance.min() - radius)


#: Demonstration lengths by task, simulated s (the paper: 5 s grasps; 80 plan steps of 0.1 s).
DEFAULT_DURATION = {"grasp": 5.0, "open_box": 8.0}


def make_teacher(robot: RobotModel, situation: Situation, q_start, period: float = 0.01):
    """The teacher of the situation's task (a box teacher plans here, which takes seconds)."""
    if situation.task == "open_box":
        return BoxTeacher(robot, situation, q_start, period)
    return GraspTeacher(robot, situation, period)


def demonstrate(world, robot: RobotModel, situation: Situation, duration: float, on_period=None):
    """Run the situation's teacher on a PhysicsWorld directly (no ROS) for duration simulated
    seconds; on_period(world, teacher, k) is called after each control period. Returns the
    teacher."""
    world.reset(situation)
    q, _ = world.joint_state()
    teacher = make_teacher(robot, situation, q, world.control_period)
    for k in range(int(round(duration / world.control_period))):
        q, _ = world.joint_state()
        world.command(teacher.command(k * world.control_period, q, world.object_poses()))
        world.step()
        if on_period is not None:
            on_period(world, teacher, k)
    return teacher
