"""Motion-rate control (paper Eq. 8-9): each tick one small joint step that decreases a learned cost,
within joint limits, velocity bounds and collision constraints. ROS-free.

TRIC's step minimizes, linearized at the current configuration q_t (g = grad_q (f o phi)(q_t),
Eq. 10):

    rho (g^T dq + delta)^2 + |dq|^2         s.t.  joint limits, |dq_i| <= v_i * period,
                                                   collision velocity dampers

i.e. it asks f to fall by delta per tick (Sec. 5.2.3: delta makes about 500 ticks from a
demonstration's start value to its end value) while keeping the step small. The QP has a fixed size
(n variables, box constraints, COLLISION_ROWS inequality rows) and is solved by proxsuite's dense
solver, re-used and warm-started tick after tick.

Priors (C_prior of Eq. 9) are constraints:
- joint limits with a margin and a per-tick step bound (the joints' velocity limits);
- collision avoidance: for the COLLISION_ROWS closest pairs within INFLUENCE (tric_sim.collision
  .Proximity: every robot geometry against the table, obstacles and box body; arm links also against
  the grasp target and the lid; arm links against the rest of the robot), a velocity damper
  n^T J dq >= -DAMPING * (d - SAFETY) keeps each pair from closing faster than a fraction of its
  remaining margin. The hand (palm and fingers) is allowed to touch the grasp target and the lid, as
  the paper's collision cost rises at the end of a grasp: contact is the goal there.

The command is a reference that integrates the steps; it may lead the measured joints by at most
MAX_LEAD, so that fingers held back by an object keep squeezing it, and a blocked arm does not wind up.
Units: rad, m, s.
"""

from dataclasses import dataclass, field

import numpy as np
import proxsuite

from tric_sim.collision import Proximity
from tric_sim.robot_model import RobotModel

COLLISION_ROWS = 6
INFLUENCE = 0.05
#: Distances kept from the scene and between the robot's own links, m.
SAFETY = 0.01
SELF_SAFETY = 0.002
DAMPING = 0.3
JOINT_MARGIN = 0.02
MAX_LEAD = 0.1
#: Convergence: the robot has come to rest, its joints having moved less than CONVERGED_MOTION (rad,
#: in norm) over the last CONVERGED_WINDOW ticks.
CONVERGED_WINDOW = 100
CONVERGED_MOTION = 0.01


@dataclass
class Tick:
    """One control tick's outcome: the target (n,), the objective's value (f for TRIC), the cost
    gradient norm, the step dq (n,), the collision pairs considered and the active constraints."""

    target: np.ndarray
    value: float
    gradient_norm: float
    step: np.ndarray
    min_distance: float
    active: list = field(default_factory=list)
    converged: bool = False


class StepQP:
    """min 1/2 dq^T H dq + c^T dq over dq (n,) with box bounds and COLLISION_ROWS rows l <= C dq;
    solve() returns None when the solver finds no solution."""

    def __init__(self, n: int):
        self.n = n
        self.qp = proxsuite.proxqp.dense.QP(n, 0, COLLISION_ROWS, True)
        self.qp.settings.eps_abs = 1e-8
        self.qp.settings.max_iter = 200
        self.qp.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
        self.initialized = False

    def solve(self, hessian, linear, rows, lower, box_low, box_high) -> np.ndarray:
        upper = np.full(COLLISION_ROWS, 1e20)
        if self.initialized:
            self.qp.update(H=hessian, g=linear, C=rows, l=lower, u=upper, l_box=box_low, u_box=box_high)
        else:
            self.qp.init(hessian, linear, None, None, rows, lower, upper, box_low, box_high)
            self.initialized = True
        self.qp.solve()
        if self.qp.results.info.status != proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED:
            return None
        return np.clip(self.qp.results.x, box_low, box_high)


class MotionRateController:
    """Runs the motion-rate step for one objective (see objectives in tric_control.objectives).

    objective(q, object_poses) -> (hessian (n, n), linear (n,), value, gradient_norm) of the
    objective's quadratic model in dq (without the |dq|^2 term, which this adds).
    """

    def __init__(self, robot: RobotModel, proximity: Proximity, objective, period: float = 0.01):
        self.robot, self.proximity, self.objective, self.period = robot, proximity, objective, period
        self.qp = StepQP(robot.n_joints)
        self.reference = None
        self.values = []
        self.history = []

    def reset(self, q: np.ndarray) -> None:
        self.reference = np.array(q, dtype=float)
        self.values = []
        self.history = []

    def tick(self, q: np.ndarray, object_poses: dict) -> Tick:
        """One control step from the measured joint positions q (n,) and the objects' poses."""
        robot = self.robot
        q = np.asarray(q, dtype=float)
        if self.reference is None:
            self.reset(q)
        self.reference = q + np.clip(self.reference - q, -MAX_LEAD, MAX_LEAD)
        hessian, linear, value, gradient_norm = self.objective(q, object_poses)
        hessian = hessian + 2.0 * np.eye(robot.n_joints)
        pairs = self.proximity.near(q, object_poses, INFLUENCE)[:COLLISION_ROWS]
        rows = np.zeros((COLLISION_ROWS, robot.n_joints))
        lower = np.full(COLLISION_ROWS, -1e20)
        max_step = robot.velocity_limits * self.period
        for k, pair in enumerate(pairs):
            rows[k] = pair.row
            safety = SAFETY if pair.with_scene else SELF_SAFETY
            # never ask for more separation than half of what a step within the bounds can give
            lower[k] = min(-DAMPING * (pair.distance - safety), 0.5 * np.abs(pair.row) @ max_step)
        box_low = np.maximum(robot.lower + JOINT_MARGIN - self.reference, -max_step)
        box_high = np.minimum(robot.upper - JOINT_MARGIN - self.reference, max_step)
        box_low, box_high = np.minimum(box_low, 0.0), np.maximum(box_high, 0.0)
        step = self.qp.solve(hessian, linear, rows, lower, box_low, box_high)
        if step is None:  # no step satisfies every constraint: hold still this tick
            step = np.zeros(robot.n_joints)
        self.reference = np.clip(self.reference + step, robot.lower, robot.upper)
        active = [pair.name for k, pair in enumerate(pairs) if rows[k] @ step <= lower[k] + 1e-7]
        active += [f"joint_limit:{robot.joint_names[i]}" for i in
                   np.flatnonzero((step <= box_low + 1e-9) & (box_low > -max_step + 1e-9)
                                  | (step >= box_high - 1e-9) & (box_high < max_step - 1e-9))]
        self.values.append(value)
        self.history.append(q)
        converged = (len(self.history) > CONVERGED_WINDOW
                     and np.linalg.norm(q - self.history[-CONVERGED_WINDOW - 1]) < CONVERGED_MOTION)
        return Tick(target=self.reference.copy(), value=value, gradient_norm=gradient_norm, step=step,
                    min_distance=pairs[0].distance if pairs else INFLUENCE, active=active,
                    converged=converged)


class ValueObjective:
    """TRIC's objective: rho (g^T dq + delta)^2 with g = (df/dy)(dphi/dq) at q."""

    def __init__(self, feature_map, value_function, delta: float, rho: float):
        if not (delta > 0 and rho > 0):
            raise ValueError("delta and rho must be positive")
        self.features, self.value_function, self.delta, self.rho = feature_map, value_function, delta, rho

    def __call__(self, q, object_poses):
        y, jacobian = self.features.with_jacobian(q, object_poses)
        value, df_dy = self.value_function.gradient(y)
        g = df_dy @ jacobian
        hessian = 2.0 * self.rho * np.outer(g, g)
        linear = 2.0 * self.rho * self.delta * g
        return hessian, linear, value, float(np.linalg.norm(g))
