"""The box-opening teacher: a trajectory optimizer in the spirit of AICO, the paper's box teacher.

It plans T = 80 steps (0.1 s each) of all the robot's joints minimizing a hand-crafted two-phase
cost, by Gauss-Newton on the stacked residuals (the normal equations are block-banded in time):

- phase 1, reach (steps 1..REACH_STEPS): the lid fingertips come from below to just under the lid's
  lip (the overhang at the box's front), passing a point a few centimetres beneath it;
- phase 2, open (the remaining steps): the fingertips follow the lip's arc about the hinge while the
  lid turns to OPEN_ANGLE: up and towards the box centre;
- always: smooth motion (squared accelerations), joint limits, the hand and arm kept clear of the
  box body and the table (and of the closed lid during the reach), and a weak posture prior.

The plan is then executed open loop, interpolated to the control rate. Units: m, rad, s.
"""

import math
import time

import numpy as np
import pinocchio as pin

from tric_sim.world import scene
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation import Situation

STEPS = 80
STEP_DURATION = 0.1
REACH_STEPS = 44
OPEN_ANGLE = 0.9
#: Fingertip targets in the lid (hinge) frame: CONTACT_INSET in from the lip's edge,
#: +-CONTACT_SPREAD across, and the tip sphere's top CONTACT_CLEARANCE under the lid (negative:
#: pressing into it).
CONTACT_INSET = 0.02
CONTACT_SPREAD = 0.033
TIP_RADIUS = 0.014
REACH_CLEARANCE = 0.003
LIFT_PRESS = -0.004
#: The reach comes to the lip from outside and below: (step, outward offset beyond the contact point
#: along the lid's x, vertical offset) of the fingertips' waypoints, m.
REACH_WAYPOINTS = ((16, 0.10, 0.04), (28, 0.08, -0.06), (37, 0.0, -0.05))
#: The margins (m) by which the robot profile's box clearance points (frame, offset along the
#: frame's z, radius) stay clear of the box body, the table and (while reaching) the lid. The hand
#: keeps the profile's box pre-shape.
SAFETY = {"box_body": 0.012, "table": 0.02, "lid": 0.006}
WEIGHTS = {
    "smooth": 30.0,
    "goal": 30.0,
    "collision": 60.0,
    "limit": 30.0,
    "posture": 0.05,
    "hand": 0.5,
}
ITERATIONS = 40


def box_distance(placement: pin.SE3, extents, point: np.ndarray):
    """Signed distance (m) of point to an oriented box (full extents) and its gradient (3,)."""
    local = placement.rotation.T @ (point - placement.translation)
    q = np.abs(local) - np.asarray(extents) / 2
    outside = np.maximum(q, 0.0)
    norm = np.linalg.norm(outside)
    if norm > 0:
        gradient_local = np.sign(local) * outside / norm
        distance = norm
    else:
        axis = int(np.argmax(q))
        gradient_local = np.zeros(3)
        gradient_local[axis] = np.sign(local[axis]) or 1.0
        distance = q[axis]
    return float(distance), placement.rotation @ gradient_local


class BoxTeacher:
    """Plans one box opening at construction (planning_time_s tells how long that took); then
    command(elapsed_s) gives the joint targets elapsed_s after the start."""

    def __init__(self, robot: RobotModel, situation: Situation, q_start, period: float = 0.01):
        if situation.task != "open_box":
            raise ValueError(f"BoxTeacher opens boxes, not task '{situation.task}'")
        self.robot, self.situation, self.period = robot, situation, period
        self.side = situation.object_dimensions[0]
        self.body = scene.se3(situation.object_position, situation.object_orientation)
        self.hinge = scene.hinge_placement(situation)
        self.lid_extents = scene.lid_extents(self.side)
        self.q_start = robot.check_configuration(q_start, "q_start")
        self.tips = [robot.frame_id(tip) for tip in robot.profile.lid_fingertips]
        self.points = [
            (robot.frame_id(frame), np.array([0.0, 0.0, offset]), radius)
            for frame, offset, radius in robot.profile.clearance["box"]
        ]
        self.nominal = robot.home.copy()
        for name, value in robot.profile.preshapes["box"].items():
            self.nominal[robot.joint_names.index(name)] = value
        start = time.perf_counter()
        self.plan = self._optimize(self._initial_guess())
        self.planning_time_s = time.perf_counter() - start
        self.phase = "reach"

    # --- targets -------------------------------------------------------------------------------

    def _lip_points(
        self, angle: float, clearance: float, out: float = 0.0, up: float = 0.0
    ) -> list:
        """World targets of the two fingertip centres under the lip with the lid opened by angle,
        moved out (along the lid's x) and up (world z) by the given offsets."""
        lid = scene.lid_placement(self.hinge, angle)
        depth = self.lid_extents[0]
        z = -(TIP_RADIUS + clearance)
        return [
            lid.act(np.array([depth - CONTACT_INSET + out, side * CONTACT_SPREAD, z]))
            + [0.0, 0.0, up]
            for side in (1, -1)
        ]

    def _goal(self, step: int):
        """Fingertip targets at a plan step (1-based), or None where the cost has no goal."""
        for waypoint, out, up in REACH_WAYPOINTS:
            if step == waypoint:
                return self._lip_points(0.0, REACH_CLEARANCE, out, up)
        if REACH_STEPS <= step:
            fraction = (step - REACH_STEPS) / (STEPS - REACH_STEPS)
            clearance = REACH_CLEARANCE if step == REACH_STEPS else LIFT_PRESS
            return self._lip_points(OPEN_ANGLE * fraction, clearance)
        return None

    # --- kinematics ----------------------------------------------------------------------------

    def _kinematics(self, q):
        robot = self.robot
        pin.computeJointJacobians(robot.model, robot.data, q)
        pin.updateFramePlacements(robot.model, robot.data)

    def _point(self, fid, offset):
        robot = self.robot
        placement = robot.data.oMf[fid]
        world_offset = placement.rotation @ offset
        jac = pin.getFrameJacobian(robot.model, robot.data, fid, pin.LOCAL_WORLD_ALIGNED)
        return placement.translation + world_offset, jac[:3] - pin.skew(world_offset) @ jac[3:]

    def _step_residuals(self, step: int, q):
        """Residuals (k,) and their Jacobian (k, n) that depend on q at one plan step only."""
        robot, n = self.robot, self.robot.n_joints
        self._kinematics(q)
        residuals, jacobians = [], []
        goal = self._goal(step)
        if goal is not None:
            for fid, target in zip(self.tips, goal):
                position, jac = self._point(fid, np.zeros(3))
                residuals.append(WEIGHTS["goal"] * (position - target))
                jacobians.append(WEIGHTS["goal"] * jac)
        obstacles = [("box_body", self.body, (self.side,) * 3)]
        if step < REACH_STEPS:
            lid = self.hinge * scene.lid_geometry_offset(self.side)
            obstacles.append(("lid", lid, self.lid_extents))
        for fid, offset, radius in self.points:
            position, jac = self._point(fid, offset)
            for role, placement, extents in obstacles:
                distance, gradient = box_distance(placement, extents, position)
                margin = SAFETY[role] + radius - distance
                if role == "lid" and fid in self.tips:
                    margin = -distance  # the fingertips may come right under the lid
                if margin > 0:
                    residuals.append(np.array([WEIGHTS["collision"] * margin]))
                    jacobians.append(-WEIGHTS["collision"] * (gradient @ jac)[None, :])
            margin = SAFETY["table"] + radius - position[2]
            if margin > 0:
                residuals.append(np.array([WEIGHTS["collision"] * margin]))
                jacobians.append(-WEIGHTS["collision"] * jac[2][None, :])
        lower = np.minimum(q - (robot.lower + 0.03), 0.0)
        upper = np.maximum(q - (robot.upper - 0.03), 0.0)
        residuals.append(WEIGHTS["limit"] * (lower + upper))
        jacobians.append(WEIGHTS["limit"] * np.diag(((lower < 0) | (upper > 0)).astype(float)))
        prior = np.full(n, WEIGHTS["posture"])
        prior[robot.hand_indices] = WEIGHTS["hand"]
        residuals.append(prior * (q - self.nominal))
        jacobians.append(np.diag(prior))
        return np.concatenate(residuals), np.vstack(jacobians)

    # --- optimization --------------------------------------------------------------------------

    def _initial_guess(self) -> np.ndarray:
        """Keyframes by inverse kinematics (below the lip, at the lip, along the arc), joined by
        interpolation from the start configuration."""
        keyframes, q = {}, self.nominal.copy()
        q[self.robot.arm_indices] = self.q_start[self.robot.arm_indices]
        waypoints = [step for step, _, _ in REACH_WAYPOINTS]
        for step in waypoints + list(range(REACH_STEPS, STEPS + 1)):
            q = self._tip_ik(q, self._goal(step))
            keyframes[step] = q.copy()
        plan = np.zeros((STEPS + 1, self.robot.n_joints))
        plan[0] = self.q_start
        anchors = [0] + waypoints + [REACH_STEPS]
        values = [self.q_start] + [keyframes[k] for k in waypoints] + [keyframes[REACH_STEPS]]
        for (a, b), (qa, qb) in zip(zip(anchors, anchors[1:]), zip(values, values[1:])):
            for step in range(a, b + 1):
                s = (step - a) / (b - a)
                plan[step] = qa + (3 * s**2 - 2 * s**3) * (qb - qa)
        for step in range(REACH_STEPS, STEPS + 1):
            plan[step] = keyframes[step]
        return plan

    def _tip_ik(self, q, targets, iterations: int = 60) -> np.ndarray:
        robot = self.robot
        for _ in range(iterations):
            self._kinematics(q)
            errors, rows = [], []
            for fid, target in zip(self.tips, targets):
                position, jac = self._point(fid, np.zeros(3))
                errors.append(target - position)
                rows.append(jac)
            error, jac = np.concatenate(errors), np.vstack(rows)
            prior = 1e-2 * np.ones(robot.n_joints)
            prior[robot.hand_indices] = 1e-1
            hessian = jac.T @ jac + np.diag(prior)
            gradient = jac.T @ error + prior * (self.nominal - q) * 0.1
            q = np.clip(
                q + np.linalg.solve(hessian, gradient), robot.lower + 0.03, robot.upper - 0.03
            )
        return q

    def _optimize(self, plan: np.ndarray) -> np.ndarray:
        """Gauss-Newton with Levenberg damping on steps 1..STEPS (step 0 is the start)."""
        n, steps = self.robot.n_joints, STEPS
        size = n * steps
        damping = 1e-2
        cost = self._cost(plan)
        for _ in range(ITERATIONS):
            hessian = np.zeros((size, size))
            gradient = np.zeros(size)
            for step in range(1, steps + 1):
                r, jac = self._step_residuals(step, plan[step])
                block = slice((step - 1) * n, step * n)
                hessian[block, block] += jac.T @ jac
                gradient[block] += jac.T @ r
            self._add_smoothness(plan, hessian, gradient)
            delta = -np.linalg.solve(hessian + damping * np.eye(size), gradient).reshape(steps, n)
            candidate = plan.copy()
            candidate[1:] += delta
            candidate_cost = self._cost(candidate)
            if candidate_cost < cost:
                plan, cost = candidate, candidate_cost
                damping = max(damping / 3, 1e-4)
                if np.abs(delta).max() < 1e-4:
                    break
            else:
                damping *= 10
        return plan

    def _add_smoothness(self, plan, hessian, gradient):
        """Accelerations q[t+1] - 2 q[t] + q[t-1] for t = 0..STEPS, with q[-1] = q[0] (start at
        rest) and q[STEPS+1] = q[STEPS] (end at rest)."""
        n, w = self.robot.n_joints, WEIGHTS["smooth"]
        padded = np.vstack([plan[:1], plan, plan[-1:]])
        for t in range(1, STEPS + 2):
            residual = w * (padded[t + 1] - 2 * padded[t] + padded[t - 1])
            coefficients = {t + 1: w, t: -2 * w, t - 1: w}
            # padded index k is plan index k - 1; the plan's own index 0 and the padding are fixed,
            # the padding at the end mirrors the last step
            columns = {}
            for k, c in coefficients.items():
                step = min(k - 1, STEPS)
                if step >= 1:
                    columns[step] = columns.get(step, 0.0) + c
            for a, ca in columns.items():
                gradient[(a - 1) * n : a * n] += ca * residual
                for b, cb in columns.items():
                    hessian[(a - 1) * n : a * n, (b - 1) * n : b * n] += ca * cb * np.eye(n)

    def _cost(self, plan) -> float:
        total = 0.0
        for step in range(1, STEPS + 1):
            total += float(np.sum(self._step_residuals(step, plan[step])[0] ** 2))
        padded = np.vstack([plan[:1], plan, plan[-1:]])
        accelerations = padded[2:] - 2 * padded[1:-1] + padded[:-2]
        return total + WEIGHTS["smooth"] ** 2 * float(np.sum(accelerations**2))

    # --- execution -----------------------------------------------------------------------------

    @property
    def duration(self) -> float:
        return STEPS * STEP_DURATION

    def command(self, elapsed_s: float, q=None, poses=None) -> np.ndarray:
        """Joint targets elapsed_s after the start: the plan, linearly interpolated (open loop: the
        measured q and poses are not used)."""
        position = min(max(elapsed_s / STEP_DURATION, 0.0), float(STEPS))
        k = min(int(math.floor(position)), STEPS - 1)
        s = position - k
        self.phase = "reach_under_lid" if position < REACH_STEPS else "lift_lid"
        q = (1 - s) * self.plan[k] + s * self.plan[k + 1]
        return np.clip(q, self.robot.lower, self.robot.upper)
