"""The motion-rate controller's core, without ROS: the QP step on hand-made problems with known
solutions, joint and velocity limits under an adversarial objective, collision rows against an
obstacle, convergence with TRIC's value objective, refused inputs, and a limit of one's own stacked
with the default ones (each limit class has its own test file). Units: rad, m, s."""

import math

import coal
import numpy as np
import pinocchio as pin
import pytest
from hand_made_values import SPHERE, SPHERE_POSES, palm_minimum_value

from tric_control.fall_pace import FallPace
from tric_control.limits import Limit, damper_bounds
from tric_control.motion_rate import (
    COLLISION_ROWS,
    CONVERGED_MOTION,
    CONVERGED_WINDOW,
    DOMAIN_MARGIN,
    DOMAIN_ROWS,
    JOINT_MARGIN,
    PRISMATIC_JOINT_MARGIN,
    SAFETY,
    STEP_QUANTUM,
    MotionRateController,
    StepQP,
    default_limits,
    joint_margins,
)
from tric_control.objectives import Objective, ValueObjective, make_objective
from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.model_file import ModelFile, value_function_arrays
from tric_learning.training.rest import RestRule
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.world import situations
from tric_sim.world.proximity import Closest, Proximity
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.shapes import coal_shape

#: "No bound" for the QP's unused inequality rows, as the controller uses it.
UNBOUNDED = 1e20


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


# --- the QP step ---------------------------------------------------------------------------------


def unused_rows(rows: int, n: int):
    """Inequality rows that constrain nothing: C (rows, n) = 0, l = -UNBOUNDED."""
    return np.zeros((rows, n)), np.full(rows, -UNBOUNDED)


def test_step_qp_unconstrained_quadratic():
    """min 1/2 x^T H x + c^T x with every bound inactive: x = -H^-1 c."""
    hessian, linear = np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-4.0, 0.0])
    step = StepQP(2, 1).solve(
        hessian, linear, *unused_rows(1, 2), np.full(2, -10.0), np.full(2, 10.0)
    )
    assert np.allclose(step, [8 / 3, -4 / 3], atol=1e-6)


def test_step_qp_active_box_bound_after_an_update():
    """The same problem with x0 <= 1: x0 = 1 and x1 minimizes what is left, 1/2 (2 x1^2 + 2 x1) so
    x1 = -1/2 (KKT: the multiplier of x0 <= 1 is 4 - 2 x0 - x1 = 3/2 > 0). The QP object solves the
    unconstrained problem first, so the second solve goes through update()."""
    qp = StepQP(2, 1)
    hessian, linear = np.array([[2.0, 1.0], [1.0, 2.0]]), np.array([-4.0, 0.0])
    qp.solve(hessian, linear, *unused_rows(1, 2), np.full(2, -10.0), np.full(2, 10.0))
    step = qp.solve(hessian, linear, *unused_rows(1, 2), np.full(2, -10.0), np.array([1.0, 10.0]))
    assert np.allclose(step, [1.0, -0.5], atol=1e-6)


def test_step_qp_active_inequality_row():
    """min 1/2 |x - a|^2 s.t. r^T x >= b with r^T a < b: the projection x = a + (b - r^T a) r /
    |r|^2; a second row that constrains nothing stays inactive."""
    a, row, bound = np.array([1.0, -2.0, 0.5]), np.array([1.0, 1.0, 0.0]), 0.5
    rows = np.array([row, np.zeros(3)])
    step = StepQP(3, 2).solve(
        np.eye(3), -a, rows, np.array([bound, -UNBOUNDED]), np.full(3, -10.0), np.full(3, 10.0)
    )
    assert np.allclose(step, a + (bound - row @ a) * row / (row @ row), atol=1e-6)
    assert np.allclose(step, [1.75, -1.25, 0.5], atol=1e-6)


def test_step_qp_solves_with_daqp_and_every_active_row_holds_exactly():
    """A feasible problem is daqp's: min 1/2 |x - a|^2 s.t. x0 + x1 >= 1 and x1 <= 0.2 (a box
    bound) from a = 0 gives x = (0.8, 0.2) with both active, the row to the last rounding."""
    qp = StepQP(2, 1)
    step = qp.solve(
        np.eye(2),
        np.zeros(2),
        np.array([[1.0, 1.0]]),
        np.array([1.0]),
        np.full(2, -1.0),
        np.array([1.0, 0.2]),
    )
    assert qp.solved_by == "daqp"
    assert np.allclose(step, [0.8, 0.2], atol=2 * STEP_QUANTUM)
    assert step[1] == 0.2 and abs(step.sum() - 1.0) <= 2 * STEP_QUANTUM


def test_step_qp_hands_conflicting_rows_to_proxsuite_and_holds_still_when_it_fails():
    """x0 >= 1 and x0 <= 0 cannot both hold: daqp reports the problem infeasible, proxsuite's
    infeasibility solving is tried, and where it ends without a solution (as on this problem, at its
    iteration limit) solve() returns None, which the controller takes as "hold still"; the next
    feasible problem is daqp's again."""
    qp = StepQP(2, 2)
    rows, box = np.array([[1.0, 0.0], [-1.0, 0.0]]), (np.full(2, -2.0), np.full(2, 2.0))
    hessian, linear = np.eye(2), np.array([0.0, -1.0])
    assert qp.solve(hessian, linear, rows, np.array([1.0, 0.0]), *box) is None
    assert qp.solved_by is None and qp.qp.results.info.iter > 0  # proxsuite ran
    step = qp.solve(hessian, linear, rows, np.array([0.5, -0.7]), *box)
    assert qp.solved_by == "daqp" and np.allclose(step, [0.5, 1.0], atol=2 * STEP_QUANTUM)


def test_step_qp_gives_the_same_step_bit_for_bit_in_every_instance():
    """A random problem of the controller's size (14 variables, 26 rows, some active) solved by 40
    solver instances made at different places in memory, each after another problem (which a warm
    start would carry over): every step is the same to the last bit, on the STEP_QUANTUM grid."""
    rng = np.random.default_rng(3)
    n, rows = 14, 26
    factor = rng.normal(size=(n, n))
    hessian, linear = factor @ factor.T + np.eye(n), 20.0 * rng.normal(size=n)
    constraint = rng.normal(size=(rows, n))
    # feasible
    lower = constraint @ rng.uniform(-0.1, 0.1, n) - np.abs(rng.normal(size=rows)) * 0.05
    low, high = np.full(n, -0.2), np.full(n, 0.2)
    kept, steps = [], []
    for _ in range(40):
        kept.append(np.empty(int(rng.integers(1, 9))))  # move the next allocations around
        qp = StepQP(n, rows)
        other = rng.normal(size=n)
        qp.solve(hessian, other, constraint, lower - 1.0, low, high)
        steps.append(
            qp.solve(hessian.copy(), linear.copy(), constraint.copy(), lower.copy(), low, high)
        )
        kept.append(qp)
    assert all(np.array_equal(step, steps[0]) for step in steps)
    assert np.array_equal(np.round(steps[0] / STEP_QUANTUM) * STEP_QUANTUM, steps[0])
    assert np.sum(constraint @ steps[0] <= lower + 1e-6) >= 2  # a problem with active rows


# --- limits under an adversarial objective -------------------------------------------------------


class NoPairs:
    """A proximity that reports no close pairs: the controller without collision rows."""

    def near(self, q, object_poses, influence):
        return Closest.none(len(q))


class Push:
    """An adversarial objective: a huge linear term pushing every joint along direction (n,) of
    +-1, past its limit; no curvature, no domain rows."""

    def __init__(self, direction: np.ndarray, strength: float = 1e6):
        self.direction, self.strength = direction, strength

    def __call__(self, q, object_poses) -> Objective:
        n = len(self.direction)
        return Objective(
            hessian=np.zeros((n, n)),
            linear=-self.strength * self.direction,
            value=0.0,
            gradient_norm=self.strength * np.sqrt(n),
        )


def measured(mode: str, target: np.ndarray, q: np.ndarray, rng) -> np.ndarray:
    """The joint positions the controller reads next: the target itself ("exact"), half-way from q
    to it ("lagging"), or the target with 0.05 rad of noise, unclipped: at times outside the joint
    limits ("noisy")."""
    if mode == "exact":
        return target.copy()
    if mode == "lagging":
        return q + 0.5 * (target - q)
    return target + rng.normal(0.0, 0.05, len(target))


@pytest.mark.parametrize("mode", ["exact", "lagging", "noisy"])
def test_targets_stay_within_joint_and_velocity_limits_under_an_adversarial_objective(robot, mode):
    """From random configurations, each joint pushed hard past one limit for PUSH_TICKS ticks and
    then past the other: no target leaves the joint limits, no target moves more than
    velocity_limits * period from the previous one, and (unless the readings are noisy) the targets
    end each push JOINT_MARGIN inside the limit pushed against."""
    period, push_ticks = 0.01, 500  # the widest joint range takes 495 full steps
    max_step = robot.velocity_limits * period
    rng = np.random.default_rng(7)
    for _ in range(3):
        direction = rng.choice([-1.0, 1.0], robot.n_joints)
        objective = Push(direction)
        controller = MotionRateController(robot, NoPairs(), objective, period)
        q = rng.uniform(robot.lower, robot.upper)
        previous = q.copy()
        for sign in (1.0, -1.0):
            objective.direction = sign * direction
            for _ in range(push_ticks):
                target = controller.tick(q, {}).target
                assert np.all(target >= robot.lower) and np.all(target <= robot.upper), target
                assert np.all(np.abs(target - previous) <= max_step * (1 + 1e-12)), (
                    target - previous
                )
                previous, q = target, measured(mode, target, q, rng)
            if mode != "noisy":
                pushed_limit = np.where(
                    sign * direction > 0, robot.upper - JOINT_MARGIN, robot.lower + JOINT_MARGIN
                )
                assert np.allclose(target, pushed_limit, atol=1e-9)


def test_a_sliding_finger_keeps_millimetres_from_its_limits_not_the_arm_s_radians():
    """The Panda's gripper finger slides 0 to 4 cm: pushed shut and then open, it stops
    PRISMATIC_JOINT_MARGIN (2 mm) inside each limit, as the arm's joints stop JOINT_MARGIN (rad)
    inside theirs; a margin of 0.02 read as metres would hold it at 2 cm, half open, both ways."""
    panda = RobotModel("panda")
    finger = panda.joint_names.index("panda_finger_joint1")
    assert list(np.flatnonzero(panda.prismatic)) == [finger]
    margins = joint_margins(panda)
    assert margins[finger] == PRISMATIC_JOINT_MARGIN and np.all(
        np.delete(margins, finger) == JOINT_MARGIN
    )
    objective = Push(-np.ones(panda.n_joints))
    controller = MotionRateController(panda, NoPairs(), objective)
    q = panda.home.copy()
    for sign, limit in ((-1.0, panda.lower), (1.0, panda.upper)):
        objective.direction = sign * np.ones(panda.n_joints)
        for _ in range(400):  # the widest range takes 267 full steps
            q = controller.tick(q, {}).target
        assert q[finger] == pytest.approx(limit[finger] - sign * PRISMATIC_JOINT_MARGIN, abs=1e-9)
        arm = panda.arm_indices
        np.testing.assert_allclose(q[arm], (limit - sign * JOINT_MARGIN)[arm], atol=1e-9)


# --- collision rows ----------------------------------------------------------------------------

#: A plate 20 cm under the hand at its home configuration (palm centre at about (0.30, 0, 0.75)).
PLATE = situations.Obstacle("box", (0.3, 0.4, 0.03), (0.40, 0.0, 0.50))


class PullPalm:
    """An objective pulling the palm centre towards a point (3,): the linear term gain * (gradient
    of the palm's distance to it); no curvature, no domain rows."""

    def __init__(self, robot: RobotModel, point, gain: float):
        self.model, self.data = robot.model, robot.model.createData()
        self.frame, self.point, self.gain = (
            robot.frame_id("palm_center"),
            np.asarray(point, dtype=float),
            gain,
        )

    def __call__(self, q, object_poses) -> Objective:
        pin.computeJointJacobians(self.model, self.data, q)
        pin.updateFramePlacements(self.model, self.data)
        towards = self.point - self.data.oMf[self.frame].translation
        jacobian = pin.getFrameJacobian(self.model, self.data, self.frame, pin.LOCAL_WORLD_ALIGNED)[
            :3
        ]
        gradient = -jacobian.T @ towards / np.linalg.norm(towards)
        n = self.model.nq
        return Objective(
            hessian=np.zeros((n, n)),
            linear=self.gain * gradient,
            value=float(np.linalg.norm(towards)),
            gradient_norm=float(np.linalg.norm(gradient)),
        )


def clearance(robot: RobotModel, q: np.ndarray, obstacle: situations.Obstacle) -> float:
    """The smallest signed distance (m) between any robot geometry and the obstacle at q, computed
    with coal directly on every geometry (not through Proximity's pre-selection)."""
    data, geometry_data = robot.model.createData(), pin.GeometryData(robot.collision_model)
    pin.updateGeometryPlacements(robot.model, data, robot.collision_model, geometry_data, q)
    shape = coal_shape(obstacle.shape, obstacle.dimensions)
    x, y, z, w = obstacle.orientation
    placement = coal.Transform3s(pin.Quaternion(w, x, y, z).matrix(), np.array(obstacle.position))
    request, result = coal.DistanceRequest(), coal.DistanceResult()
    distances = []
    for geometry, world in zip(robot.collision_model.geometryObjects, geometry_data.oMg):
        result.clear()
        distances.append(
            coal.distance(
                geometry.geometry,
                coal.Transform3s(world.rotation, world.translation),
                shape,
                placement,
                request,
                result,
            )
        )
    return min(distances)


@pytest.mark.parametrize("point", [(0.42, 0.0, 0.40), (0.35, 0.0, 0.20)])
def test_collision_rows_keep_the_hand_off_an_obstacle(robot, point):
    """The palm pulled to a point under the plate, the target integrated as the measured q: with
    collision rows the robot presses on the plate and stays within SAFETY less 3 mm of
    linearization error of it; without them the hand goes through."""
    situation = situations.Situation(
        name="plate",
        task="grasp",
        object_kind="sphere",
        object_dimensions=(0.04,),
        object_position=(0.6, -0.5, 0.1),
        obstacles=(PLATE,),
    ).validate()
    poses = {"object": (situation.object_position, situation.object_orientation)}
    closest = {}
    for name, proximity in (("rows", Proximity(robot, situation)), ("none", NoPairs())):
        controller = MotionRateController(robot, proximity, PullPalm(robot, point, gain=50.0))
        q, distances, touched = robot.home.copy(), [], False
        for _ in range(300):
            tick = controller.tick(q, poses)
            q = tick.target
            distances.append(clearance(robot, q, PLATE))
            touched |= any(pair.endswith("/obstacle_0") for pair in tick.active)
        closest[name] = min(distances)
        if name == "rows":
            assert touched and distances[-1] < SAFETY + 0.002, "the hand should press on the plate"
    assert closest["rows"] >= SAFETY - 0.003, closest
    assert closest["none"] < -0.001, closest


# --- convergence with TRIC's objective -----------------------------------------------------------


def palm_distance_value(definition: FeatureDefinition, low: float, high: float) -> ValueFunction:
    """A linear value function f = u = (d[palm,object] - low) / (high - low): the one kept feature
    is the palm's distance to the object, scaled as if the demonstrations spanned [low, high] m."""
    kept = np.array([definition.feature_names.index("d[palm,object]")])
    return ValueFunction(
        Scaling(kept, np.array([low]), np.array([high]), definition.size),
        np.zeros((0, 1)),
        np.zeros(0),
        np.array([1.0]),
    )


def test_value_objective_descends_at_delta_and_converges_at_rest(robot):
    """f falls by delta per tick while the palm approaches the sphere; the model's domain stops the
    palm (u >= -DOMAIN_MARGIN, i.e. 21 cm from the object's centre, before the fingers touch it),
    the robot comes to rest, and the tick says converged exactly when its joints have moved less
    than CONVERGED_MOTION over the
    last CONVERGED_WINDOW ticks."""
    definition = FeatureDefinition.for_task("grasp", robot)
    situation = situations.sphere("sphere", (0.55, 0.0, 0.45))
    poses = {"object": (situation.object_position, situation.object_orientation)}
    delta = 0.002
    value_function = palm_distance_value(definition, 0.25, 1.0)
    objective = ValueObjective(FeatureMap(definition, robot), value_function, delta, rho=100.0)
    controller = MotionRateController(robot, Proximity(robot, situation), objective)
    q, history, ticks = robot.home.copy(), [], []
    while len(ticks) < 600 and not (ticks and ticks[-1].converged):
        history.append(q)
        ticks.append(controller.tick(q, poses))
        q = ticks[-1].target
    values = [tick.value for tick in ticks]
    assert (values[0] - values[100]) / 100 == pytest.approx(delta, rel=0.1)
    assert ticks[-1].converged, f"not at rest after {len(ticks)} ticks"
    for k, tick in enumerate(ticks):
        motion = (
            np.linalg.norm(history[k] - history[k - CONVERGED_WINDOW])
            if k >= CONVERGED_WINDOW
            else np.inf
        )
        assert tick.converged == (motion < CONVERGED_MOTION), k
    assert "feature_range:d[palm,object]" in ticks[-1].active
    assert values[-1] >= -DOMAIN_MARGIN - 1e-3


# --- refused inputs ------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "delta, rho", [(0.0, 1.0), (-0.01, 1.0), (float("nan"), 1.0), (0.01, 0.0), (0.01, -1.0)]
)
def test_value_objective_refuses_non_positive_delta_or_rho(robot, delta, rho):
    definition = FeatureDefinition.for_task("grasp", robot)
    with pytest.raises(ValueError, match="delta and rho must be positive"):
        ValueObjective(
            FeatureMap(definition, robot), palm_distance_value(definition, 0.0, 1.0), delta, rho
        )


def test_make_objective_runs_tric_models_and_refuses_the_others(robot):
    definition = FeatureDefinition.for_task("grasp", robot)
    arrays = value_function_arrays(palm_distance_value(definition, 0.0, 1.0))
    objective = make_objective(
        ModelFile("tric", definition, arrays, {"delta": 0.002, "rho": 50.0}), robot
    )
    assert isinstance(objective, ValueObjective) and (objective.delta, objective.rho) == (
        0.002,
        50.0,
    )
    assert objective.kept_names == ["d[palm,object]"]

    with pytest.raises(
        ValueError,
        match=r"model kind 'svm' cannot be run by this controller "
        r"\(runnable kinds: tric, dpl_joint, dpl_finger\)",
    ):
        make_objective(ModelFile("svm", definition, {"w": np.zeros(3)}), robot)
    with pytest.raises(ValueError, match="no usable 'delta'"):
        make_objective(ModelFile("tric", definition, arrays, {"rho": 50.0}), robot)
    with pytest.raises(ValueError, match="delta must be finite and positive"):
        make_objective(ModelFile("tric", definition, arrays, {"delta": -0.002, "rho": 50.0}), robot)
    assert objective.done_value is None  # chosen by no selection
    info = {"delta": 0.002, "rho": 50.0, "done_value": -41.5}
    assert make_objective(ModelFile("tric", definition, arrays, info), robot).done_value == -41.5
    for bad in ("low", math.inf):
        with pytest.raises(ValueError, match="done_value must be a finite number"):
            make_objective(
                ModelFile("tric", definition, arrays, {**info, "done_value": bad}), robot
            )


# --- a limit of one's own ------------------------------------------------------------------------


class KeepBelow(Limit):
    """Joint `joint` stays below `angle` (rad), approached as a velocity damper (the example of
    docs/controller.md)."""

    rows = 1

    def __init__(self, joint: int, angle: float, damping: float = 0.3):
        self.joint, self.angle, self.damping = joint, angle, damping

    def constrain(self, state, rows, lower):
        rows[0] = 0.0
        rows[0, self.joint] = -1.0  # the margin angle - q falls as q rises
        damper_bounds(
            rows, np.array([self.angle - state.q[self.joint]]), self.damping, state.max_step, lower
        )

    def active(self, state, step, binding):
        return [f"keep_below:{self.joint}"] if binding[0] else []


def test_a_limit_of_one_s_own_is_stacked_with_the_others(robot):
    """An objective pushing every joint up: with KeepBelow(0, 0.3) added to the default limits,
    joint 0 approaches 0.3 rad and stops there (named active), while the others still go to their
    limits; the QP has one row more."""
    direction = np.ones(robot.n_joints)
    limits = default_limits(robot, {}) + [KeepBelow(0, 0.3)]
    controller = MotionRateController(robot, NoPairs(), Push(direction), limits=limits)
    assert controller.qp.rows == COLLISION_ROWS + DOMAIN_ROWS + 1
    q, named = np.zeros(robot.n_joints), False
    for _ in range(400):
        tick = controller.tick(q, {})
        q = tick.target
        named |= "keep_below:0" in tick.active
    assert 0.29 < q[0] <= 0.3 and named
    assert np.allclose(q[1:], (robot.upper - JOINT_MARGIN)[1:], atol=1e-6)


def test_a_value_with_a_minimum_brings_the_controller_to_rest_there_and_only_there(robot):
    """f(u) = u - sigmoid(10 (u + 0.1)) of the palm's scaled distance to the sphere u has its
    minimum at u* (about 0.11, the palm 33 cm from it; from the start, 39 cm, f falls towards it):
    the controller descends f to u*, and its rest rule (the joints slower than 0.01 rad/s and f not
    falling over 0.25 s) holds there and at no tick before, while u is still on its way."""
    definition = FeatureDefinition.for_task("grasp", robot)
    situation, poses = SPHERE, SPHERE_POSES
    value_function = palm_minimum_value(definition)
    grid = np.linspace(-0.05, 1.0, 50001)
    f = grid - 1.0 / (1.0 + np.exp(-(10.0 * grid + 1.0)))
    u_star = grid[np.argmin(f)]
    rule = RestRule(speed=0.01, fall=0.0)
    objective = ValueObjective(
        FeatureMap(definition, robot), value_function, 0.002, rho=100.0, rest=rule
    )
    controller = MotionRateController(robot, Proximity(robot, situation), objective)
    features = FeatureMap(definition, robot)
    index = definition.feature_names.index("d[palm,object]")
    q, ticks, us = robot.home.copy(), [], []
    while len(ticks) < 3000 and not (ticks and ticks[-1].converged):
        ticks.append(controller.tick(q, poses))
        q = ticks[-1].target
        us.append((features(q, poses)[index] - 0.25) / 0.75)
    assert ticks[-1].converged, f"not at rest after {len(ticks)} ticks (u {us[-1]:.3f})"
    assert abs(us[-1] - u_star) < 0.02, (us[-1], u_star)
    assert us[0] - u_star > 0.05  # it had a way to go
    assert not any(tick.converged for tick in ticks[:-1])


# --- the fall pace (tric_control.fall_pace) ---------------------------------------------------


PACE_DELTA = 0.002


def paced_run(robot, pace, blocked_from: int, ticks: int = 400):
    """The steps' norms and f of a controller descending f = the palm's scaled distance to a sphere
    (palm_distance_value) by PACE_DELTA a tick, with the fall pace pace (or None); from tick
    blocked_from on the measured joints no longer follow the command (the robot is held)."""
    situation = situations.sphere("sphere", (0.55, 0.0, 0.45))
    poses = {"object": (situation.object_position, situation.object_orientation)}
    definition = FeatureDefinition.for_task("grasp", robot)
    value_function = palm_distance_value(definition, 0.25, 1.0)
    objective = ValueObjective(FeatureMap(definition, robot), value_function, PACE_DELTA, rho=100.0)
    controller = MotionRateController(robot, Proximity(robot, situation), objective, fall_pace=pace)
    q, norms, values = robot.home.copy(), [], []
    for k in range(ticks):
        tick = controller.tick(q, poses)
        norms.append(float(np.linalg.norm(tick.step)))
        values.append(tick.value)
        if k < blocked_from:
            q = tick.target
    return np.array(norms), np.array(values)


def test_the_controller_keeps_the_paper_s_descent_while_the_world_follows(robot):
    paced, values = paced_run(robot, FallPace(), blocked_from=10**6, ticks=150)
    plain, _ = paced_run(robot, None, blocked_from=10**6, ticks=150)
    np.testing.assert_array_equal(paced, plain)
    assert (values[0] - values[100]) / 100 == pytest.approx(PACE_DELTA, rel=0.1)


def test_a_held_robot_s_steps_shrink_with_the_pace_and_not_without_it(robot):
    """Held from tick 100 (f stops falling): the paper's controller asks the same step on and on;
    with the pace the step shrinks to a small share of it within a few windows."""
    paced, _ = paced_run(robot, FallPace(knee=0.25, window_ticks=50, floor=0.05), blocked_from=100)
    plain, _ = paced_run(robot, None, blocked_from=100)
    assert plain[-1] == pytest.approx(plain[150], rel=1e-6) and plain[-1] > 0
    assert paced[-1] < 0.1 * plain[-1]
    np.testing.assert_array_equal(paced[:100], plain[:100])


def test_a_pace_needs_an_objective_that_asks_a_fall(robot):
    class NoFall:
        def __call__(self, q, object_poses):
            n = len(q)
            return Objective(np.zeros((n, n)), np.zeros(n), 0.0, 0.0)

    situation = situations.sphere("sphere", (0.55, 0.0, 0.45))
    with pytest.raises(ValueError, match="delta"):
        MotionRateController(robot, Proximity(robot, situation), NoFall(), fall_pace=FallPace())
