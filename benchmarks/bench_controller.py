"""Controller benchmarks: the motion-rate tick of a trained grasp model over a real episode, and the
same step done with pin-pink.

The model: trained on the demonstrations of six situations of the sphere grid (SITUATIONS), read
from their bags in bags/sphere when they are there, else demonstrated offline here; with the default
hyper-parameters (K = 30 hidden units) but half the noisy samples (TRAINING), which leaves the size of
the tick's work unchanged. The episode: EPISODE_TICKS control periods of the grid's centre situation
(one of those trained on) on a tric_sim.physics.PhysicsWorld, the controller commanding the simulated
robot from its home towards the sphere (the log says how close the palm came).

controller_tick_p50_ms, controller_tick_p99_ms: wall time of MotionRateController.tick (features,
  Jacobian, f and its gradient, domain rows, collision distances, QP), ms. Target: p99 <= 0.5.
controller_objective_p50_ms, controller_proximity_p50_ms, controller_qp_p50_ms: the tick's parts
  (ValueObjective: features, Jacobian, f, gradient and domain rows; Proximity.near: collision
  distances and rows; the rest: QP assembly and solve), medians, ms.
pink_tick_p50_ms, pink_tick_p99_ms: the same step with pin-pink, replayed on the episode's states:
  Configuration.update(q), then solve_ik (solver "proxqp") with one scalar task whose Jacobian is
  the same gradient g = (df/dy)(dphi/dq) and whose error is delta (cost sqrt(2 rho), damping 2: the
  minimizer of rho (g dq + delta)^2 + |dq|^2), under the joint position limits (gain 1) and velocity
  limits. It has no collision distances and no domain rows: it does less than the controller's tick.
"""

import pathlib
import sys
import time

import numpy as np
import pink
from pink.limits import ConfigurationLimit, VelocityLimit
from pink.tasks import Task

from tric_control.motion_rate import MotionRateController
from tric_control.objectives import make_objective
from tric_learning import model_file
from tric_learning.recording import load_dataset, record_offline
from tric_learning.training import TrainingConfig, train
from tric_sim import situations
from tric_sim.collision import Proximity
from tric_sim.physics import PhysicsWorld
from tric_sim.robot_model import RobotModel

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
    """A TRIC grasp model trained on the demonstrations of SITUATIONS: their bags, or recorded here."""
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
    log(f"trained on {len(dataset.demos)} demonstrations in {result.train_time_s:.1f} s "
        f"({len(result.model.scaling.kept)} kept features, K = {result.model.hidden_units})")
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
        self.near = Timed(proximity.near)


def controller_episode(robot: RobotModel, model: model_file.ModelFile, situation) -> tuple:
    """Run the controller on a PhysicsWorld for EPISODE_TICKS periods. Returns the tick times and
    those of its objective and proximity parts (s each), the states (q, object poses) it saw and
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
            states.append((q, poses))
            world.command(tick.target)
            world.step()
        robot.forward(q)
        reach = np.linalg.norm(robot.frame_placement("palm_center").translation - situation.object_position)
        log(f"episode: f from {controller.values[0]:.3f} to {controller.values[-1]:.3f}, palm "
            f"{reach * 1000:.0f} mm from the object's centre, closest pair {tick.min_distance * 1000:.1f} mm")
        return ticks, objective.times, proximity.near.times, states, world.control_period
    finally:
        world.close()


class ValueTask(Task):
    """pink task e = delta, J = g = (df/dy)(dphi/dq) at the configuration (1, n): its QP objective
    is 1/2 cost^2 (g dq + delta)^2, TRIC's value term (Eq. 8-10). Set object_poses before solving."""

    def __init__(self, objective, cost: float):
        super().__init__(cost=cost)
        self.features, self.value_function = objective.features, objective.value_function
        self.delta = objective.delta
        self.object_poses = {}

    def compute_error(self, configuration) -> np.ndarray:
        return np.array([self.delta])

    def compute_jacobian(self, configuration) -> np.ndarray:
        y, jacobian = self.features.with_jacobian(configuration.q, self.object_poses)
        return (self.value_function.gradient(y)[1] @ jacobian)[None, :]

    def __repr__(self):
        return f"ValueTask(delta={self.delta}, cost={self.cost})"


def pink_replay(robot: RobotModel, model: model_file.ModelFile, states, period: float) -> list:
    """Wall times (s) of the pink step at each state (q is clipped into the joint limits, which
    pink's solve_ik requires)."""
    objective = make_objective(model, robot)
    task = ValueTask(objective, cost=float(np.sqrt(2.0 * objective.rho)))
    configuration = pink.Configuration(robot.model, robot.model.createData(), robot.home)
    limits = [ConfigurationLimit(robot.model, config_limit_gain=1.0), VelocityLimit(robot.model)]
    times = []
    for q, poses in states:
        q = np.clip(q, robot.lower, robot.upper)
        start = time.perf_counter()
        task.object_poses = poses
        configuration.update(q)
        pink.solve_ik(configuration, [task], period, solver="proxqp", damping=2.0, limits=limits)
        times.append(time.perf_counter() - start)
    return times


def percentile_ms(times, q: float) -> float:
    """The q-th percentile of times (s), in ms."""
    return round(float(np.percentile(times, q)) * 1e3, 3)


def run() -> dict:
    robot = RobotModel()
    model = grasp_model(robot)
    situation = situations.sphere_grid()[EPISODE_SITUATION]
    ticks, objective, proximity, states, period = controller_episode(robot, model, situation)
    pink_times = pink_replay(robot, model, states, period)
    rest = np.array(ticks) - np.array(objective) - np.array(proximity)
    results = {
        "controller_tick_p50_ms": percentile_ms(ticks, 50), "controller_tick_p99_ms": percentile_ms(ticks, 99),
        "controller_objective_p50_ms": percentile_ms(objective, 50),
        "controller_proximity_p50_ms": percentile_ms(proximity, 50),
        "controller_qp_p50_ms": percentile_ms(rest, 50),
        "pink_tick_p50_ms": percentile_ms(pink_times, 50), "pink_tick_p99_ms": percentile_ms(pink_times, 99),
    }
    log(f"{len(ticks)} ticks: " + ", ".join(f"{k} {v}" for k, v in results.items()))
    return results
