"""Motion-rate control (paper Eq. 8-9): each tick one small joint step that decreases a learned
cost, within joint limits, velocity bounds and collision constraints. ROS-free.

TRIC's step minimizes, linearized at the current configuration q_t (g = grad_q (f o phi)(q_t),
Eq. 10):

    rho (g^T dq + delta)^2 + |dq|^2 + C_prior         s.t.  the limits' bounds and rows

i.e. it asks f to fall by delta per tick (Sec. 5.2.3: delta makes about 500 ticks from a
demonstration's start value to its end value) while keeping the step small. The objective
(tric_control.objectives) gives its quadratic model; the priors (C_prior of Eq. 9) are limits
(tric_control.limits), each adding its piece of the QP: by default the joints' limits with a margin
and a per-tick step bound (JointLimits), velocity dampers on the COLLISION_ROWS closest collision
pairs within INFLUENCE (CollisionDamper, with the safety distances below), on the DOMAIN_ROWS
features nearest the bounds of the model's domain (DomainDamper), and the soft side of the task's
contacts as a cost (SoftContact). What the hand may press, how deep and from which side is the
task's (tric_sim.world.scene.contacts, through the Proximity), handed to the limits when they are
built. The QP has a fixed size (n variables with bounds, the limits' inequality rows) and is solved
by daqp's active-set solver, or by proxsuite where its rows conflict (StepQP). Each solve starts
cold and its solution is rounded: an episode is then the same, bit for bit, in every run, through
the nodes or offline.

The command is a reference that integrates the steps; it may lead the measured joints by at most
MAX_LEAD (the arm: a blocked arm does not wind up) or MAX_HAND_LEAD (the hand: fingers held back by
an object keep squeezing it, with a force that grows with the lead).
Units: rad, m, s.
"""

from dataclasses import dataclass, field
from typing import cast

import daqp
import numpy as np
import proxsuite

from tric_control.fall_pace import FallPace, PaceState
from tric_control.limits import (
    UNBOUNDED_BELOW,
    CollisionDamper,
    ContactRules,
    DomainDamper,
    JointLimits,
    Limit,
    SoftContact,
    StepState,
)
from tric_sim.world.proximity import Proximity
from tric_sim.world.robot_model import RobotModel

#: Inequality rows of the QP for the closest collision pairs and for the features nearest the
#: bounds of the model's training range (a count each).
COLLISION_ROWS = 10
DOMAIN_ROWS = 8
#: How far a feature may leave the training range [0, 1] of its rescaled value (dimensionless).
DOMAIN_MARGIN = 0.05
#: Collision pairs farther apart than this are not considered, m.
INFLUENCE = 0.05
#: Distances kept from the scene and between the robot's own links, m.
SAFETY = 0.01
SELF_SAFETY = 0.002
#: The dampers' gain: the fraction of its margin a distance (or a feature's) may lose per tick.
DAMPING = 0.3
#: The joint limits less this margin bound the command: rad for a revolute joint, m for a
#: prismatic one (2 mm of, say, a parallel gripper finger's 40 mm: a margin in radians read as
#: metres would take half of it; docs/decisions/joint-margins.md).
JOINT_MARGIN = 0.02
PRISMATIC_JOINT_MARGIN = 0.002
#: How far the command may lead the measured arm and hand joints, rad (see the module docstring).
MAX_LEAD = 0.03
MAX_HAND_LEAD = 0.03
#: The step QP's solution is rounded to a multiple of this (rad): far coarser than the last-bit
#: differences between solver instances (1e-16), far finer than a tick's step (up to 1e-2); see
#: StepQP.
STEP_QUANTUM = 2.0**-26
#: Convergence without a rest rule (a DPL policy, a model made before models carried one): the
#: robot has come to rest, its joints having moved less than CONVERGED_MOTION (rad, in norm) over
#: the last CONVERGED_WINDOW ticks.
CONVERGED_WINDOW = 100
CONVERGED_MOTION = 0.01


def default_limits(robot: RobotModel, contacts: dict, domain_damper: bool = True) -> list:
    """The controller's limits: joint limits, collision and domain dampers (domain_damper: False
    leaves the domain damper out, for studies), and the soft side of the task's contacts ({scene
    body name: tric_sim.world.scene.Contact})."""
    rules = ContactRules(contacts)
    return [
        CollisionDamper(rules, COLLISION_ROWS, SAFETY, SELF_SAFETY, DAMPING),
        *([DomainDamper(DOMAIN_ROWS, DAMPING)] if domain_damper else []),
        JointLimits(robot.lower, robot.upper, robot.joint_names, joint_margins(robot)),
        SoftContact(rules),
    ]


def joint_margins(robot: RobotModel) -> np.ndarray:
    """The margin (n,) kept from each joint's limits: JOINT_MARGIN rad for a revolute joint,
    PRISMATIC_JOINT_MARGIN m for a prismatic one."""
    return np.where(robot.prismatic, PRISMATIC_JOINT_MARGIN, JOINT_MARGIN)


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


_PER_QUANTUM = 1.0 / STEP_QUANTUM
#: daqp's "no bound" (its DAQP_INF), and its tolerance for a row's violation (in the rows' units).
DAQP_UNBOUNDED = 1e30
DAQP_PRIMAL_TOLERANCE = 1e-9
#: The largest entry of an array, as a plain ufunc reduction (ndarray.max adds a Python layer).
_largest = np.maximum.reduce
#: The solver outcomes whose step is used.
_SOLVED = (
    proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED,
    proxsuite.proxqp.QPSolverOutput.PROXQP_SOLVED_CLOSEST_PRIMAL_FEASIBLE,
)


class StepQP:
    """min 1/2 dq^T H dq + c^T dq over dq (n,) with bounds on each variable and `rows` inequality
    rows l <= C dq; solve() returns None when no solver finds a solution.

    The step is solved by daqp, a dual active-set solver for small dense QPs: its solution is exact
    up to rounding (every active row holds with equality). Where the rows conflict (dampers that
    cannot all hold), daqp reports the problem infeasible, and proxsuite is tried instead with
    primal infeasibility solving, for the step closest to feasible; where it ends without a
    solution too, solve() returns None and the controller holds still. The cost is divided by its
    largest coefficient first (the same minimizer), so that proxsuite's absolute tolerance means the
    same for objectives of every scale. Each solve starts cold, and its solution is rounded to a
    multiple of STEP_QUANTUM: a compiled solver's result for the same problem may differ in its last
    bit with where its buffers lie in memory (vectorized loops), and contacts amplify that into
    other episodes. Rounded, two instances give the same step unless an entry lies within 1e-16 of a
    rounding boundary (about 1 in 10^8 entries). Measured over the 600 ticks of the episode of
    benchmarks/bench_controller.py (2026-12-02): daqp 6.4 us per solve (median, with its Python
    call), proxsuite 35 us; daqp's rows are violated by 1e-17 at most, proxsuite's by 2e-8
    (docs/decisions/controller-tick-speed.md)."""

    def __init__(self, n: int, rows: int):
        self.n, self.rows = n, rows
        # daqp's bounds: the n variables' first, then the rows' (their upper ones unbounded)
        self._daqp_upper = np.full(n + rows, DAQP_UNBOUNDED)
        self._daqp_lower = np.empty(n + rows)
        self._daqp_kinds = np.zeros(n + rows, dtype=np.intc)  # inequalities
        self.qp = proxsuite.proxqp.dense.QP(n, 0, rows, True)
        self.qp.settings.eps_abs = 1e-9
        self.qp.settings.max_iter = 100
        self.qp.settings.max_iter_in = 50
        # conflicting dampers: solve for the closest feasible constraints instead of failing
        self.qp.settings.primal_infeasibility_solving = True
        self.qp.settings.initial_guess = proxsuite.proxqp.InitialGuess.NO_INITIAL_GUESS
        self.initialized = False
        self._upper = np.full(rows, -UNBOUNDED_BELOW)
        #: Which solver gave the last step: "daqp", "proxsuite" or None (none found one).
        self.solved_by: str | None = None

    def solve(self, hessian, linear, rows, lower, box_low, box_high) -> np.ndarray | None:
        # the cost divided by its largest coefficient (same minimizer): the solver's absolute
        # tolerance then means the same for an objective of any scale
        scale = max(
            1.0,
            float(_largest(np.abs(hessian), axis=None)),
            float(_largest(np.abs(linear), axis=None)),
        )
        if scale > 1.0:
            hessian, linear = hessian / scale, linear / scale
        n, upper, below = self.n, self._daqp_upper, self._daqp_lower
        upper[:n] = box_high
        below[:n] = box_low
        below[n:] = lower
        x, _, exit_flag, _ = daqp.solve(
            hessian, linear, rows, upper, below, self._daqp_kinds, primal_tol=DAQP_PRIMAL_TOLERANCE
        )
        if exit_flag > 0:
            self.solved_by = "daqp"
        else:
            x = self._closest_feasible(hessian, linear, rows, lower, box_low, box_high)
            if x is None:
                self.solved_by = None
                return None
            self.solved_by = "proxsuite"
        # x / STEP_QUANTUM is exactly x * 2**26; rint rounds half to even, as np.round does
        step = np.rint(np.asarray(x) * _PER_QUANTUM) * STEP_QUANTUM
        return np.maximum(np.minimum(step, box_high), box_low)

    def _closest_feasible(self, hessian, linear, rows, lower, box_low, box_high):
        """proxsuite's solution (n,) of the problem with primal infeasibility solving, or None."""
        if self.initialized:
            self.qp.update(
                H=hessian, g=linear, C=rows, l=lower, u=self._upper, l_box=box_low, u_box=box_high
            )
        else:
            self.qp.init(hessian, linear, None, None, rows, lower, self._upper, box_low, box_high)
            self.initialized = True
        self.qp.solve()
        if self.qp.results.info.status not in _SOLVED:
            return None
        return self.qp.results.x


class MotionRateController:
    """Runs the motion-rate step for one objective (see tric_control.objectives) under limits.

    objective(q, object_poses) -> tric_control.objectives.Objective: the quadratic model of the cost
    in dq (without the |dq|^2 term, which this adds), the cost's value and gradient norm, and the
    domain rows.
    proximity.near(q, object_poses, INFLUENCE) -> tric_sim.world.proximity.Closest: the collision
    pairs. contacts: what the hand may press ({scene body name: tric_sim.world.scene.Contact}),
    default the proximity's (its situation's task's). limits: the QP's pieces
    (tric_control.limits.Limit), default default_limits(robot, contacts, domain_damper); the
    inequality rows are stacked in their order.
    max_lead: how far the command may lead the measured joints, rad, one for all or (n,); default
    MAX_LEAD on the arm and MAX_HAND_LEAD on the hand. fall_pace: ask a share of the objective's
    delta that follows the fall f has made (tric_control.fall_pace.FallPace), or None (default:
    delta every tick, the paper's); refused with an objective that has no delta (DPL's).
    """

    def __init__(
        self,
        robot: RobotModel,
        proximity: Proximity,
        objective,
        period: float = 0.01,
        *,
        contacts: dict | None = None,
        limits: list | None = None,
        max_lead=None,
        domain_damper: bool = True,
        fall_pace: FallPace | None = None,
    ):
        if fall_pace is not None and not getattr(objective, "delta", 0) > 0:
            raise ValueError("a fall pace needs an objective that asks a fall (TRIC's delta)")
        self.fall_pace = fall_pace
        self._pace: PaceState | None = None
        self.robot, self.proximity, self.objective, self.period = (
            robot,
            proximity,
            objective,
            period,
        )
        if max_lead is None:
            max_lead = np.full(robot.n_joints, MAX_LEAD)
            max_lead[robot.hand_indices] = MAX_HAND_LEAD
        self.max_lead = np.broadcast_to(np.asarray(max_lead, dtype=float), (robot.n_joints,)).copy()
        if not np.all(np.isfinite(self.max_lead) & (self.max_lead >= 0)):
            raise ValueError("max_lead must be finite and >= 0 rad")
        if limits is None:
            limits = default_limits(
                robot,
                getattr(proximity, "contacts", {}) if contacts is None else contacts,
                domain_damper,
            )
        self.limits = list(limits)
        n = robot.n_joints
        slices, start = [], 0
        for limit in self.limits:
            slices.append(slice(start, start + limit.rows))
            start += limit.rows
        self.qp = StepQP(n, start)
        self.reference: np.ndarray | None = None
        self.values: list[float] = []
        self.history: list[np.ndarray] = []
        self._step_metric = 2.0 * np.eye(n)  # the |dq|^2 term's Hessian
        self._max_step = robot.velocity_limits * period
        self._state = StepState(max_step=self._max_step)
        self._hessian, self._linear = np.empty((n, n)), np.empty(n)
        self._rows, self._lower = np.zeros((start, n)), np.full(start, UNBOUNDED_BELOW)
        self._low, self._high = np.empty(n), np.empty(n)
        # the limits that use each way of shaping the step (those that override it); those with rows
        # get their views into the QP's rows and lower bounds, those that name what binds the slice
        # of their rows
        self._costs = [limit for limit in self.limits if _overrides(limit, "add_cost")]
        self._boxes = [limit for limit in self.limits if _overrides(limit, "bound")]
        self._constraining = [
            (limit, self._rows[rows_of], self._lower[rows_of])
            for limit, rows_of in zip(self.limits, slices)
            if limit.rows
        ]
        self._naming = [
            (limit, rows_of)
            for limit, rows_of in zip(self.limits, slices)
            if _overrides(limit, "active")
        ]

    def reset(self, q: np.ndarray, paced: bool = True) -> None:
        """Start again from q (n,): the reference, the rest rule's history and the pace's state;
        paced False: no pace until the next reset (an objective that asks no fall of f)."""
        self.reference = np.array(q, dtype=float)
        self.values = []
        self.history = []
        paced = paced and self.fall_pace is not None
        self._pace = cast(FallPace, self.fall_pace).start() if paced else None

    def tick(self, q: np.ndarray, object_poses: dict) -> Tick:
        """One control step from the measured joint positions q (n,) and the objects' poses."""
        robot = self.robot
        q = np.asarray(q, dtype=float)
        if self.reference is None:
            self.reset(q)
        previous = cast(np.ndarray, self.reference)  # reset has set it
        self.reference = q + np.maximum(np.minimum(previous - q, self.max_lead), -self.max_lead)
        model = self.objective(q, object_poses)
        state = self._state
        state.q, state.reference, state.objective = q, self.reference, model
        state.closest = closest = self.proximity.near(q, object_poses, INFLUENCE)
        hessian, linear = self._hessian, self._linear
        np.add(model.hessian, self._step_metric, out=hessian)
        linear[:] = model.linear
        if self._pace is not None:
            linear *= self._pace.share(model.value, self.objective.delta)
        for limit in self._costs:
            limit.add_cost(state, hessian, linear)
        low, high = self._low, self._high
        low.fill(-np.inf)
        high.fill(np.inf)
        for limit in self._boxes:
            limit.bound(state, low, high)
        state.low, state.high = low, high
        rows, lower = self._rows, self._lower
        for limit, rows_view, lower_view in self._constraining:
            limit.constrain(state, rows_view, lower_view)
        step = self.qp.solve(hessian, linear, rows, lower, low, high)
        if step is None:  # the solver found no step: hold still this tick
            step = np.zeros(robot.n_joints)
        # the command moves by at most one velocity-bounded step per tick, within the joint limits
        max_step = self._max_step
        target = previous + np.maximum(
            np.minimum(self.reference + step - previous, max_step), -max_step
        )
        self.reference = np.maximum(np.minimum(target, robot.upper), robot.lower)
        binding = rows @ step <= lower + 1e-7
        active = []
        for limit, rows_of in self._naming:
            active += limit.active(state, step, binding[rows_of])
        self.values.append(model.value)
        self.history.append(q)
        converged = self._at_rest()
        return Tick(
            target=self.reference.copy(),
            value=model.value,
            gradient_norm=model.gradient_norm,
            step=step,
            min_distance=float(closest.distances[0]) if len(closest) else INFLUENCE,
            active=active,
            converged=converged,
        )

    def _at_rest(self) -> bool:
        """Whether the robot has come to rest: by the objective's rest rule (the model's, taken
        from its demonstrations' ends: over its window the joints slower than its speed and f
        falling slower than its fall), else by moving less than CONVERGED_MOTION over the last
        CONVERGED_WINDOW ticks."""
        rule = getattr(self.objective, "rest", None)
        if rule is None:
            if len(self.history) <= CONVERGED_WINDOW:
                return False
            motion = self.history[-1] - self.history[-CONVERGED_WINDOW - 1]
            return bool(motion @ motion < CONVERGED_MOTION**2)
        window = max(int(round(rule.window_s / self.period)), 1)
        if len(self.history) <= window:
            return False
        span = window * self.period
        speed = float(np.linalg.norm(self.history[-1] - self.history[-window - 1])) / span
        return rule.holds(speed, (self.values[-window - 1] - self.values[-1]) / span)


def _overrides(limit: Limit, method: str) -> bool:
    """Whether the limit's class overrides Limit's (empty) method."""
    return getattr(type(limit), method) is not getattr(Limit, method)
