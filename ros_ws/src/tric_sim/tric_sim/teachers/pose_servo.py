"""The grasp teacher's arm motion towards a palm pose (PoseServo): steepest descent of the pose
error in joint space, at bounded speed, within the joint limits, above the table and (while
reaching) clear of the object, as a small QP solved with ProxQP each control period. Units: m, rad,
s."""

import numpy as np
import pinocchio as pin
import proxsuite

from tric_sim.world.robot_model import RobotModel
from tric_sim.world.shapes import object_surface

#: The palm pose servo descends the pose error E = |dx|^2 + ORIENTATION_LENGTH^2 |drot|^2 (m^2)
#: along its joint-space gradient, with steps that make E fall at SERVO_RATE (1/s): exponentially,
#: as long as the joints' velocity limits allow.
SERVO_RATE = 6.0
ORIENTATION_LENGTH = 0.3
#: The palm centre and the fingertips are kept at least TABLE_CLEARANCE above the table top
#: (z = 0), m.
TABLE_CLEARANCE = 0.03
#: While reaching, the robot profile's grasp clearance points (frame, offset, radius) keep
#: OBJECT_CLEARANCE (m, beyond their own radius) from the object, so that the hand goes around it to
#: the pre-grasp pose.
OBJECT_CLEARANCE = 0.015
#: Velocity-damper rate: the fraction of the remaining margin a point may close per period.
DAMPER_RATE = 0.5


class PoseServo:
    """The arm's motion towards a palm pose: each call returns joint increments (7,) along the
    steepest descent of the pose error in joint space, at bounded speed, within joint limits, above
    the table and (while reaching) clear of the object. Moving down a gradient in joint space is
    what TRIC assumes of a teacher (paper Sec. 3.2.3 and Proposition 1)."""

    def __init__(self, robot: RobotModel, period: float):
        self.robot, self.period = robot, period
        profile = robot.profile
        self.palm = robot.frame_id(profile.palm)
        self.clearance_frames = [robot.frame_id(f) for f in (profile.palm, *profile.fingertips)]
        self.hand_points = [
            (robot.frame_id(frame), np.array([0.0, 0.0, offset]), radius)
            for frame, offset, radius in profile.clearance["grasp"]
        ]
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
        # the constraints' rows and lower bounds: lists, then arrays
        rows: list | np.ndarray
        lower: list | np.ndarray
        rows, lower = [], []
        for fid in self.clearance_frames:
            z = robot.data.oMf[fid].translation[2]
            rows.append(
                pin.getFrameJacobian(robot.model, robot.data, fid, pin.LOCAL_WORLD_ALIGNED)[2, arm]
            )
            # velocity damper: approach the floor gradually
            lower.append(0.5 * (TABLE_CLEARANCE - z))
        for fid, offset, radius in self.hand_points:
            if avoid is None:
                rows.append(np.zeros(len(arm)))
                lower.append(-1e20)
                continue
            placement = robot.data.oMf[fid]
            world_offset = placement.rotation @ offset
            jac = pin.getFrameJacobian(robot.model, robot.data, fid, pin.LOCAL_WORLD_ALIGNED)
            jac_point = (jac[:3] - pin.skew(world_offset) @ jac[3:])[:, arm]
            distance, normal = object_surface(
                avoid[0], avoid[1], avoid[2], (placement.translation + world_offset)[None, :]
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
