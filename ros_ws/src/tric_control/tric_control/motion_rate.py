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
  .Proximity: every robot geometry against every scene body, arm links against the rest of the
  robot), a velocity damper n^T J dq >= -DAMPING * (d - safety) keeps each pair from closing faster
  than a fraction of its remaining margin. The safety distance is SAFETY for the scene, SELF_SAFETY
  between the robot's links, -TOUCH_DEPTH for the hand against the grasp target and -PUSH_DEPTH
  against the lid: as in the paper, where the collision cost rises at the end of a grasp, the fingers
  come to touch the object (contact is the goal there) and may press into it a few millimetres,
  which makes the grip; the lid is there to be pushed open, so the hand may press deeper and feels no
  soft touch prior (with both, measured on the first 12 test boxes: 0 opened, every episode stalled
  with a finger under the lip; without: 4). Only from beneath, though (Proximity decides): from
  above, pressing can only shut the lid, and the hand keeps SAFETY from it (without that, measured:
  fingers pressing the closed lid's top, its hinge forced below 0).

- the model's domain: a learned value function is only known where it was trained. Each kept
  feature u (scaled to [0, 1] over the demonstrations and noisy samples) is kept within
  [-DOMAIN_MARGIN, 1 + DOMAIN_MARGIN]: the DOMAIN_ROWS features nearest their bounds get the same
  kind of damper, du/dq dq >= -DAMPING * (u - bound) (signs mirrored at the upper bound). Without it
  the linear part of f extrapolates, and the controller drives the hand into configurations never
  demonstrated (fingers bent backwards) where f keeps falling.

The command is a reference that integrates the steps; it may lead the measured joints by at most
MAX_LEAD, so that fingers held back by an object keep squeezing it, and a blocked arm does not wind up.
Units: rad, m, s.
"""

import math
from dataclasses import dataclass, field

import numpy as np
import proxsuite

from tric_sim.collision import Proximity
from tric_sim.robot_model import RobotModel

COLLISION_ROWS = 10
DOMAIN_ROWS = 8
DOMAIN_MARGIN = 0.05
INFLUENCE = 0.05
#: Distances kept from the scene and between the robot's own links, and how far the hand may press
#: into the grasp target or the lid, m.
SAFETY = 0.01
SELF_SAFETY = 0.002
TOUCH_DEPTH = 0.005
PUSH_DEPTH = 0.015
SAFETY_BY_ROLE = {"self": SELF_SAFETY, "touch": -TOUCH_DEPTH, "push": -PUSH_DEPTH}
#: Soft touch prior: within TOUCH_SOFT of the grasp target the hand is pushed back with this
#: weight (relative to the step-size term). 3 mm measured best on the sphere test set (1 cm left the
#: fingers ~1 cm off the surface, grasp cost 0.085; without the prior the fingers jam: 0.40; 2 mm
#: lost one of 8 grasps; 3 mm: 0.042 mean, 0.069 max over 15).
TOUCH_SOFT = 0.003
TOUCH_WEIGHT = 3.0
DAMPING = 0.3
JOINT_MARGIN = 0.02
MAX_LEAD = 0.03
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


#: The solver outcomes whose step is used.
_SOLVED = (proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED,
           proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED_CLOSEST_PRIMAL_FEASIBLE)


class StepQP:
    """min 1/2 dq^T H dq + c^T dq over dq (n,) with box bounds and `rows` inequality rows
    l <= C dq; solve() returns None when the solver finds no solution."""

    def __init__(self, n: int, rows: int):
        self.n, self.rows = n, rows
        self.qp = proxsuite.proxqp.dense.QP(n, 0, rows, True)
        self.qp.settings.eps_abs = 1e-7
        self.qp.settings.max_iter = 100
        self.qp.settings.max_iter_in = 50
        # conflicting dampers: solve for the closest feasible constraints instead of failing
        self.qp.settings.primal_infeasibility_solving = True
        self.qp.settings.initial_guess = proxsuite.proxqp.InitialGuess.WARM_START_WITH_PREVIOUS_RESULT
        self.initialized = False
        self._upper = np.full(rows, 1e20)

    def solve(self, hessian, linear, rows, lower, box_low, box_high) -> np.ndarray:
        if self.initialized:
            self.qp.update(H=hessian, g=linear, C=rows, l=lower, u=self._upper, l_box=box_low, u_box=box_high)
        else:
            self.qp.init(hessian, linear, None, None, rows, lower, self._upper, box_low, box_high)
            self.initialized = True
        self.qp.solve()
        if self.qp.results.info.status not in _SOLVED:
            return None
        return np.clip(self.qp.results.x, box_low, box_high)


class MotionRateController:
    """Runs the motion-rate step for one objective (see tric_control.objectives).

    objective(q, object_poses) -> Objective: the quadratic model of the cost in dq (without the
    |dq|^2 term, which this adds), the cost's value and gradient norm, and the domain rows.
    """

    def __init__(self, robot: RobotModel, proximity: Proximity, objective, period: float = 0.01):
        self.robot, self.proximity, self.objective, self.period = robot, proximity, objective, period
        self.qp = StepQP(robot.n_joints, COLLISION_ROWS + DOMAIN_ROWS)
        self.reference = None
        self.values = []
        self.history = []
        self._step_metric = 2.0 * np.eye(robot.n_joints)        # the |dq|^2 term's Hessian
        self._max_step = robot.velocity_limits * period
        self._lowest = robot.lower + JOINT_MARGIN                 # the box's joint limits
        self._highest = robot.upper - JOINT_MARGIN

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
        previous = self.reference
        self.reference = q + np.clip(self.reference - q, -MAX_LEAD, MAX_LEAD)
        model = self.objective(q, object_poses)
        hessian = model.hessian + self._step_metric
        linear = model.linear
        pairs = self.proximity.near(q, object_poses, INFLUENCE)[:COLLISION_ROWS]
        for pair in pairs:
            # the soft part of the touch prior: the hand is pushed back from the object within
            # TOUCH_SOFT, as by a spring of stiffness TOUCH_WEIGHT / |row|^2 in the step's metric
            if pair.role == "touch" and pair.distance < TOUCH_SOFT:
                weight = TOUCH_WEIGHT / max(pair.row @ pair.row, 1e-9)
                hessian += 2.0 * weight * np.outer(pair.row, pair.row)
                linear = linear + 2.0 * weight * (pair.distance - TOUCH_SOFT) * pair.row
        max_step = self._max_step
        # each row: the gradient of a margin that must stay >= 0 and the margin now; never ask for
        # more than half of what a step within the bounds can give. Unused rows: 0 >= -1e20.
        rows = np.zeros((COLLISION_ROWS + DOMAIN_ROWS, robot.n_joints))
        margins = np.full(COLLISION_ROWS + DOMAIN_ROWS, np.nan)
        if pairs:
            rows[:len(pairs)] = [pair.row for pair in pairs]
            margins[:len(pairs)] = [pair.distance - SAFETY_BY_ROLE.get(pair.role, SAFETY) for pair in pairs]
        domain = len(model.domain_margins[:DOMAIN_ROWS])
        if domain:
            rows[COLLISION_ROWS:COLLISION_ROWS + domain] = model.domain_rows[:domain]
            margins[COLLISION_ROWS:COLLISION_ROWS + domain] = model.domain_margins[:domain]
        used = ~np.isnan(margins)
        lower = np.where(used, np.minimum(-DAMPING * margins, (0.5 * np.abs(rows)) @ max_step), -1e20)
        box_low = np.maximum(self._lowest - self.reference, -max_step)
        box_high = np.minimum(self._highest - self.reference, max_step)
        box_low, box_high = np.minimum(box_low, 0.0), np.maximum(box_high, 0.0)
        step = self.qp.solve(hessian, linear, rows, lower, box_low, box_high)
        if step is None:  # the solver found no step: hold still this tick
            step = np.zeros(robot.n_joints)
        # the command moves by at most one velocity-bounded step per tick, within the joint limits
        target = previous + np.clip(self.reference + step - previous, -max_step, max_step)
        self.reference = np.clip(target, robot.lower, robot.upper)
        binding = (rows @ step <= lower + 1e-7).tolist()
        active = [pair.name for pair, hit in zip(pairs, binding) if hit]
        active += [f"feature_range:{name}" for name, hit in zip(model.domain_names[:domain], binding[COLLISION_ROWS:])
                   if hit]
        active += [f"joint_limit:{robot.joint_names[i]}" for i in
                   np.flatnonzero((step <= box_low + 1e-9) & (box_low > -max_step + 1e-9)
                                  | (step >= box_high - 1e-9) & (box_high < max_step - 1e-9))]
        self.values.append(model.value)
        self.history.append(q)
        if len(self.history) > CONVERGED_WINDOW:
            motion = q - self.history[-CONVERGED_WINDOW - 1]
            converged = motion @ motion < CONVERGED_MOTION ** 2
        else:
            converged = False
        return Tick(target=self.reference.copy(), value=model.value, gradient_norm=model.gradient_norm, step=step,
                    min_distance=pairs[0].distance if pairs else INFLUENCE, active=active,
                    converged=converged)


@dataclass
class Objective:
    """An objective's quadratic model at q: 1/2 dq^T hessian dq + linear^T dq, the cost's value and
    gradient norm, and the domain rows: the gradients (k, n) of margins (k,) that must stay >= 0,
    nearest their bound first, with the names of their features."""

    hessian: np.ndarray
    linear: np.ndarray
    value: float
    gradient_norm: float
    domain_rows: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    domain_margins: np.ndarray = field(default_factory=lambda: np.zeros(0))
    domain_names: list = field(default_factory=list)


def domain_rows(u: np.ndarray, du_dq: np.ndarray, count: int, moving: np.ndarray):
    """The count features nearest the bounds of their training range (+-DOMAIN_MARGIN) among the
    moving ones (indices into the kept features: those a step can change, not, say, the box's
    position seen from the robot's base), from the scaled kept features u (s,) and their Jacobian
    du_dq (s, n): the gradients of their margins (count, n), the margins (count,) and the features'
    indices into the kept features, nearest first."""
    scaled = u[moving]
    to_low, to_high = scaled + DOMAIN_MARGIN, 1.0 + DOMAIN_MARGIN - scaled
    margins = np.minimum(to_low, to_high)
    nearest = np.argsort(margins)[:count]
    # the upper bound's margin falls as u rises
    rows = du_dq[moving[nearest]] * np.where(to_low[nearest] <= to_high[nearest], 1.0, -1.0)[:, None]
    return rows, margins[nearest], moving[nearest]


class ValueObjective:
    """TRIC's objective: rho (g^T dq + delta)^2 with g = (df/dy)(dphi/dq) at q. After each call,
    scaled_features (s,) and value_gradient (s,) hold u and df/du at that q (for the status)."""

    def __init__(self, feature_map, value_function, delta: float, rho: float, feature_names=None):
        if not (delta > 0 and rho > 0):
            raise ValueError("delta and rho must be positive")
        self.features, self.value_function, self.delta, self.rho = feature_map, value_function, delta, rho
        names = feature_names or feature_map.definition.feature_names
        self.kept_names = [names[k] for k in value_function.scaling.kept]
        self._moving = np.flatnonzero(feature_map.moves_with_q[value_function.scaling.kept])
        self._factor = value_function.scaling.factor[:, None]
        self.scaled_features = self.value_gradient = None

    def __call__(self, q, object_poses) -> Objective:
        y, jacobian = self.features.with_jacobian(q, object_poses)
        scaling = self.value_function.scaling
        u = scaling.transform(y)
        value, df_du = self.value_function.scaled_gradient(u)
        self.scaled_features, self.value_gradient = u, df_du
        du_dq = jacobian[scaling.kept] * self._factor                          # (s, n)
        g = df_du @ du_dq
        rows, margins, nearest = domain_rows(u, du_dq, DOMAIN_ROWS, self._moving)
        return Objective(hessian=2.0 * self.rho * np.outer(g, g), linear=2.0 * self.rho * self.delta * g,
                         value=value, gradient_norm=math.sqrt(g @ g), domain_rows=rows, domain_margins=margins,
                         domain_names=[self.kept_names[k] for k in nearest])
