"""Controller benchmarks: the motion-rate tick of a trained grasp model over a real episode, and the
same step done with pin-pink.

The model: trained on the demonstrations of six situations of the sphere grid (SITUATIONS), read
from their bags in bags/sphere when they are there, else demonstrated offline here; with the default
hyper-parameters (K = 30 hidden units) but half the noisy samples (TRAINING), which leaves the size
of the tick's work unchanged. The episode: EPISODE_TICKS control periods of the grid's centre
situation (one of those trained on) on a tric_sim.physics.simulation.PhysicsWorld, the controller
commanding the simulated robot from its home towards the sphere (the log says how close the palm
came). The comparison with pink replays the episode's states: at each, our tick (its reference set
to the episode's target after it, so that it sees the very same problems) and the two pink steps
below, in turns (which runs first rotates state by state, so that none always finds the caches the
others left).

controller_tick_p50_ms, controller_tick_p99_ms: wall time of MotionRateController.tick (features,
  Jacobian, f and its gradient, domain rows, collision distances, the limits, QP), ms. Target: p99
  <= 0.5.
controller_objective_compiled: 1 when the objective ran compiled (tric_control._value_kernel, as
  make setup builds it), 0 when it ran the numpy reference.
controller_objective_p50_ms, controller_proximity_p50_ms, controller_qp_p50_ms: the tick's parts
  (ValueObjective: features, Jacobian, f, gradient and domain rows; Proximity.near: collision
  distances and rows; the rest: the limits, QP assembly and solve), medians, ms.
pink_tick_p50_ms, pink_tick_p99_ms: the same step with pin-pink, the same task under the same
  limits: Configuration.update(q), the collision distances (Proximity.near), then solve_ik (solver
  "proxqp") with TRIC's value as one scalar task (Jacobian g = (df/dy)(dphi/dq), error delta, cost
  sqrt(2 rho), damping 2: the minimizer of rho (g dq + delta)^2 + |dq|^2; computed by the same
  ValueObjective, domain rows included), the soft side of contact as a second task, and as limits
  pink's joint position limits (shrunk by the controller's joint margins, gain 1) and velocity
  limits and this controller's collision and domain dampers (the same classes, their rows handed to
  pink). Our tick, in place of pink's solve_ik, warm-starts one fixed-size QP and bounds the step
  by a box.
controller_replay_p50_ms: our tick in the replay, ms.
controller_vs_pink: controller_replay_p50_ms / pink_tick_p50_ms. Target: < 1.
pink_bare_tick_p50_ms: pink doing less, as the first version of this benchmark had it: the value
  task (features and f's gradient) under joint position and velocity limits only, no collision
  distances, domain rows or contact; controller_vs_pink_bare: ours over it.
"""

import pathlib
import sys
import time

import numpy as np
import pink
from pink.limits import ConfigurationLimit, Limit, VelocityLimit
from pink.tasks import Task

from tric_control.limits import CollisionDamper, DomainDamper, SoftContact, StepState
from tric_control.motion_rate import INFLUENCE, MotionRateController, default_limits, joint_margins
from tric_control.objectives import COMPILED, make_objective
from tric_learning import model_file
from tric_learning.bags.loader import load_dataset
from tric_learning.recording import record_offline
from tric_learning.training.value import TrainingConfig, train
from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.world import situations
from tric_sim.world.proximity import Proximity
from tric_sim.world.robot_model import RobotModel

SPHERE_BAGS = pathlib.Path(__file__).resolve().parent.parent / "bags" / "sphere"
#: The sphere grid situations trained on (indices into situations.sphere_grid()): the grid's middle
#: layer; the episode runs on its centre.
SITUATIONS = (1, 4, 7, 10, 13, 16)
EPISODE_SITUATION = 13
DEMO_DURATION_S = 5.0
TRAINING = TrainingConfig(noisy_samples=30)
EPISODE_TICKS = 600


def log(message: str) -> None:
    print(f"[bench_controller] {message}", file=sys.stderr, flush=True)


def grasp_model(robot: RobotModel) -> model_file.ModelFile:
    """A TRIC grasp model trained on the demonstrations of SITUATIONS: their bags, or recorded
    here."""
    grid = situations.sphere_grid()
    chosen = [grid[k] for k in SITUATIONS]
    bags = [SPHERE_BAGS / f"{situation.name}.mcap" for situation in chosen]
    if all(bag.is_file() for bag in bags):
        log(f"loading {len(bags)} demonstrations from {SPHERE_BAGS}")
        dataset = load_dataset(bags, robot)
    else:
        log(f"no bags in {SPHERE_BAGS}: demonstrating {len(chosen)} situations")
        dataset = record_offline(robot, chosen, DEMO_DURATION_S)
    result = train(dataset, robot, TRAINING)
    log(
        f"trained on {len(dataset.demos)} demonstrations in {result.train_time_s:.1f} s "
        f"({len(result.model.scaling.kept)} kept features, K = {result.model.hidden_units})"
    )
    return model_file.from_training(result, dataset)


class Timed:
    """Wraps a callable and records the wall time of each call, s."""

    def __init__(self, function):
        self.function, self.times = function, []

    def __call__(self, *args):
        start = time.perf_counter()
        out = self.function(*args)
        self.times.append(time.perf_counter() - start)
        return out


class TimedProximity:
    """A Proximity whose near() calls are timed."""

    def __init__(self, proximity: Proximity):
        self.near, self.contacts = Timed(proximity.near), proximity.contacts


class ValueTask(Task):
    """pink task e = delta, J = g = (df/dy)(dphi/dq) at the configuration (1, n): its QP objective
    is 1/2 cost^2 (g dq + delta)^2, TRIC's value term (Eq. 8-10). g comes from objective(q, poses)
    (object_poses set before solving), whose model is kept in state.objective for the domain
    limit."""

    def __init__(self, objective, cost: float, state: StepState):
        super().__init__(cost=cost)
        self.objective, self.delta, self.state = objective, objective.delta, state
        self.object_poses = {}

    def compute_error(self, configuration) -> np.ndarray:
        return np.array([self.delta])

    def compute_jacobian(self, configuration) -> np.ndarray:
        self.state.objective = self.objective(configuration.q, self.object_poses)
        return self.state.objective.gradient[None, :]

    def __repr__(self):
        return f"ValueTask(delta={self.delta}, cost={self.cost})"


class BareValueTask(ValueTask):
    """The value task from the features and f's gradient only (no domain rows)."""

    def compute_jacobian(self, configuration) -> np.ndarray:
        y, jacobian = self.objective.features.with_jacobian(configuration.q, self.object_poses)
        return (self.objective.value_function.gradient(y)[1] @ jacobian)[None, :]


class LimitCost(Task):
    """A motion-rate limit's cost (tric_control.limits.Limit.add_cost) as a pink task."""

    def __init__(self, limit, state: StepState, n: int):
        super().__init__(cost=1.0)
        self.limit, self.state, self.n = limit, state, n

    def compute_qp_objective(self, configuration):
        hessian, linear = np.zeros((self.n, self.n)), np.zeros(self.n)
        self.limit.add_cost(self.state, hessian, linear)
        return hessian, linear

    def compute_error(self, configuration) -> np.ndarray:
        return np.zeros(0)

    def compute_jacobian(self, configuration) -> np.ndarray:
        return np.zeros((0, self.n))

    def __repr__(self):
        return f"LimitCost({type(self.limit).__name__})"


class LimitRows(Limit):
    """A motion-rate limit's inequality rows (lower <= rows dq) as a pink limit (-rows dq <=
    -lower)."""

    def __init__(self, limit, state: StepState, n: int):
        self.limit, self.state = limit, state
        self.rows, self.lower = np.zeros((limit.rows, n)), np.zeros(limit.rows)

    def compute_qp_inequalities(self, configuration, dt):
        self.limit.constrain(self.state, self.rows, self.lower)
        return -self.rows, -self.lower


class PinkStep:
    """One step with pin-pink for the same task under the same limits (see the module docstring), or
    (bare) the value task under joint position and velocity limits only."""

    def __init__(
        self, robot: RobotModel, model: model_file.ModelFile, situation, period: float, bare: bool
    ):
        objective = make_objective(model, robot)
        self.robot, self.period, self.bare = robot, period, bare
        self.state = StepState(max_step=robot.velocity_limits * period)
        cost = float(np.sqrt(2.0 * objective.rho))
        self.task = (BareValueTask if bare else ValueTask)(objective, cost, self.state)
        self.configuration = pink.Configuration(robot.model, robot.model.createData(), robot.home)
        self.tasks, self.limits = [self.task], [VelocityLimit(robot.model)]
        if bare:
            self.limits.append(ConfigurationLimit(robot.model, config_limit_gain=1.0))
            return
        margined, margins = robot.model.copy(), joint_margins(robot)
        margined.lowerPositionLimit = robot.lower + margins
        margined.upperPositionLimit = robot.upper - margins
        self.limits.append(ConfigurationLimit(margined, config_limit_gain=1.0))
        self.proximity = Proximity(robot, situation)
        defaults = default_limits(robot, self.proximity.contacts)
        n = robot.n_joints
        self.limits += [
            LimitRows(limit, self.state, n)
            for limit in defaults
            if isinstance(limit, (CollisionDamper, DomainDamper))
        ]
        self.tasks += [
            LimitCost(limit, self.state, n) for limit in defaults if isinstance(limit, SoftContact)
        ]

    def __call__(self, q, poses) -> None:
        """One step from q (clipped into the joint limits, which pink's solve_ik requires)."""
        q = np.clip(q, self.robot.lower, self.robot.upper)
        self.task.object_poses = poses
        self.configuration.update(q)
        if not self.bare:
            self.state.q = self.state.reference = q
            self.state.closest = self.proximity.near(q, poses, INFLUENCE)
        pink.solve_ik(
            self.configuration,
            self.tasks,
            self.period,
            solver="proxqp",
            damping=2.0,
            limits=self.limits,
        )


def controller_episode(robot: RobotModel, model: model_file.ModelFile, situation) -> dict:
    """Run the controller on a PhysicsWorld for EPISODE_TICKS periods. Returns the wall times (s) of
    the ticks and of their objective and proximity parts, the states (q, object poses, target) and
    the control period (s)."""
    world = PhysicsWorld(robot)
    try:
        world.reset(situation)
        objective = Timed(make_objective(model, robot))
        proximity = TimedProximity(Proximity(robot, situation))
        controller = MotionRateController(robot, proximity, objective, world.control_period)
        ticks, states = [], []
        for _ in range(EPISODE_TICKS):
            q, _ = world.joint_state()
            poses = world.object_poses()
            start = time.perf_counter()
            tick = controller.tick(q, poses)
            ticks.append(time.perf_counter() - start)
            states.append((q, poses, tick.target))
            world.command(tick.target)
            world.step()
        robot.forward(q)
        reach = np.linalg.norm(
            robot.frame_placement("palm_center").translation - situation.object_position
        )
        log(
            f"episode: f from {controller.values[0]:.3f} to {controller.values[-1]:.3f}, palm "
            f"{reach * 1000:.0f} mm from the object's centre, closest pair "
            f"{tick.min_distance * 1000:.1f} mm"
        )
        return {
            "tick": ticks,
            "objective": objective.times,
            "proximity": proximity.near.times,
            "states": states,
            "period": world.control_period,
        }
    finally:
        world.close()


def replay(
    robot: RobotModel, model: model_file.ModelFile, situation, states, period: float
) -> dict:
    """Wall times (s) of our tick and of the two pink steps at each state of the episode, in turns
    (which runs first rotates state by state). Our controller replays the episode: after each tick
    its reference is set to the episode's target, so that it sees the very same problems."""
    controller = MotionRateController(
        robot, Proximity(robot, situation), make_objective(model, robot), period
    )
    controller.reset(states[0][0])
    pinks = {
        "pink": PinkStep(robot, model, situation, period, bare=False),
        "pink_bare": PinkStep(robot, model, situation, period, bare=True),
    }
    times = {"tick": [], "pink": [], "pink_bare": []}
    order = list(times)
    for k, (q, poses, target) in enumerate(states):
        for name in order[k % 3 :] + order[: k % 3]:
            start = time.perf_counter()
            if name == "tick":
                controller.tick(q, poses)
            else:
                pinks[name](q, poses)
            times[name].append(time.perf_counter() - start)
        controller.reference = target.copy()
    return times


def percentile_ms(times, q: float) -> float:
    """The q-th percentile of times (s), in ms."""
    return round(float(np.percentile(times, q)) * 1e3, 3)


def run() -> dict:
    robot = RobotModel()
    model = grasp_model(robot)
    situation = situations.sphere_grid()[EPISODE_SITUATION]
    episode = controller_episode(robot, model, situation)
    turns = replay(robot, model, situation, episode["states"], episode["period"])
    rest = (
        np.array(episode["tick"]) - np.array(episode["objective"]) - np.array(episode["proximity"])
    )
    results = {
        "controller_tick_p50_ms": percentile_ms(episode["tick"], 50),
        "controller_tick_p99_ms": percentile_ms(episode["tick"], 99),
        "controller_objective_p50_ms": percentile_ms(episode["objective"], 50),
        "controller_proximity_p50_ms": percentile_ms(episode["proximity"], 50),
        "controller_qp_p50_ms": percentile_ms(rest, 50),
        "controller_replay_p50_ms": percentile_ms(turns["tick"], 50),
        "pink_tick_p50_ms": percentile_ms(turns["pink"], 50),
        "pink_tick_p99_ms": percentile_ms(turns["pink"], 99),
        "pink_bare_tick_p50_ms": percentile_ms(turns["pink_bare"], 50),
        "controller_objective_compiled": int(COMPILED),
    }
    results["controller_vs_pink"] = round(
        results["controller_replay_p50_ms"] / results["pink_tick_p50_ms"], 3
    )
    results["controller_vs_pink_bare"] = round(
        results["controller_replay_p50_ms"] / results["pink_bare_tick_p50_ms"], 3
    )
    log(f"{len(episode['tick'])} ticks: " + ", ".join(f"{k} {v}" for k, v in results.items()))
    return results
