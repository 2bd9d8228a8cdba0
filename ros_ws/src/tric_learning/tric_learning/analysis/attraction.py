"""Whether f has an attracting minimum where the demonstrations end (paper Sec. 4.2.3, Prop. 2).

Prop. 2: if f o phi(q_T) is a minimum of f, the motion-rate controller of Eq. 8 converges to the
subspace phi(q) = y_T from any start near it. This measures it on the learned f alone, as the
proposition sets it: no priors (no collisions, contacts or domain limits), the objects where they
are at the demonstration's end. From starts drawn around each demonstration's last q (each joint
from N(q_T, sigma^2) within its limits), the step of Eq. 8-9 linearized without C_prior,

    dq = -rho delta g / (1 + rho |g|^2),    g = grad_q (f o phi)(q),

with the model's own delta and rho, bounded by the joints' velocity limits over one control period
and kept within the joint limits, is applied until the state comes to rest (the controller's
criterion: it moved less than REST_MOTION rad over REST_WINDOW ticks) or the tick budget is spent.
A rollout comes back when it is at rest nearer y_T than it started, in the scaled features u (the
space f sees): within RETURN_SHARE of its start's distance. It reports too how far below f(y_T) the
rollout went, in units of the demonstration's own fall f(y_0) - f(y_T): a minimum at y_T means none.
And whether f has its minimum at the demonstrations' ends at all (end_measures): the share of
noisy samples around each q_T (as L_n draws them: collision-free, within the limits) where f is
above f(y_T), and f's gradient norm at y_T against its median along the demonstration (a minimum:
every sample above, a gradient near zero).
ROS-free; units rad, s.
"""

from dataclasses import dataclass

import numpy as np

from tric_learning.features import FeatureMap
from tric_learning.training.dataset import Dataset
from tric_learning.training.hyperparameters import SAMPLE_CONTACT_TOLERANCE
from tric_learning.training.samples import draws_around, truncated_gaussian
from tric_learning.value_function import ValueFunction
from tric_sim.world.collision import SceneCollision
from tric_sim.world.robot_model import RobotModel

#: The controller's convergence criterion (tric_control.motion_rate: CONVERGED_WINDOW and
#: CONVERGED_MOTION, which tric_learning may not import; a test keeps them equal).
REST_WINDOW, REST_MOTION = 100, 0.01
#: The control period of the rollouts, s (the controller's, 100 Hz).
PERIOD = 0.01
#: A rollout at rest within this share of its start's distance to y_T (in u) has come back.
RETURN_SHARE = 0.5
#: Defaults: rollouts per demonstration, the starts' standard deviation per joint (rad, the noisy
#: samples' sigma), the tick budget (twice the 500 ticks delta is set for, Sec. 5.2.3).
ROLLOUTS, SIGMA, TICKS = 4, 0.05, 1000


@dataclass
class Rollout:
    """One rollout from a perturbed end state: the demo's index, whether it came to rest and at
    which tick (the budget if not), whether it came back, its distance to y_T in u at the start and
    the end, and the lowest f it reached less f(y_T), over the demo's fall f(y_0) - f(y_T)."""

    demo: int
    at_rest: bool
    ticks: int
    came_back: bool
    start_distance: float
    end_distance: float
    undershoot: float


def descend(
    model: ValueFunction,
    feature_map: FeatureMap,
    robot: RobotModel,
    q: np.ndarray,
    object_poses: dict,
    delta: float,
    rho: float,
    ticks: int,
):
    """The rollout of the prior-free step (see the module docstring) from q (n,): (the states
    (k + 1, n) it went through, the values f (k + 1,), whether it came to rest)."""
    max_step = robot.velocity_limits * PERIOD
    states, values = [np.array(q, dtype=float)], []
    for _ in range(ticks):
        y, jacobian = feature_map.with_jacobian(states[-1], object_poses)
        value, df_dy = model.gradient(y)
        values.append(value)
        g = df_dy @ jacobian
        step = np.clip(-rho * delta * g / (1.0 + rho * (g @ g)), -max_step, max_step)
        states.append(np.clip(states[-1] + step, robot.lower, robot.upper))
        if len(states) > REST_WINDOW:
            motion = states[-1] - states[-1 - REST_WINDOW]
            if motion @ motion < REST_MOTION**2:
                values.append(model.value(feature_map(states[-1], object_poses)))
                return np.array(states), np.array(values), True
    values.append(model.value(feature_map(states[-1], object_poses)))
    return np.array(states), np.array(values), False


def rollouts_from_demo_ends(
    model: ValueFunction,
    dataset: Dataset,
    robot: RobotModel,
    delta: float,
    rho: float,
    rollouts: int = ROLLOUTS,
    sigma: float = SIGMA,
    ticks: int = TICKS,
    seed: int = 0,
    feature_map=None,
) -> list:
    """[Rollout] of rollouts starts around each demo's last state (see the module docstring),
    reproducibly from seed; ValueError for delta or rho not positive. feature_map: phi and its
    Jacobian (default FeatureMap of the dataset's definition)."""
    if not (delta > 0 and rho > 0):
        raise ValueError("delta and rho must be positive (a model file records both)")
    if rollouts < 1 or ticks < 1 or not sigma > 0:
        raise ValueError("rollouts and ticks must be at least 1 and sigma positive")
    feature_map = feature_map or FeatureMap(dataset.definition, robot)
    rng = np.random.default_rng(seed)
    found = []
    for i, demo in enumerate(dataset.demos):
        poses, end = demo.object_poses[-1], model.scaling.transform(demo.y[-1])
        end_value, fall = model.value(demo.y[-1]), model.value(demo.y[0]) - model.value(demo.y[-1])
        starts = truncated_gaussian(
            rng, np.repeat(demo.q[-1][None], rollouts, axis=0), sigma, robot.lower, robot.upper
        )
        for start in starts:
            states, values, at_rest = descend(
                model, feature_map, robot, start, poses, delta, rho, ticks
            )
            u = model.scaling.transform(feature_map.batch(states[[0, -1]], poses))
            start_distance, end_distance = np.linalg.norm(u - end, axis=1)
            found.append(
                Rollout(
                    demo=i,
                    at_rest=at_rest,
                    ticks=len(states) - 1,
                    came_back=bool(at_rest and end_distance <= RETURN_SHARE * start_distance),
                    start_distance=float(start_distance),
                    end_distance=float(end_distance),
                    undershoot=float(max(end_value - values.min(), 0.0) / fall)
                    if fall > 0
                    else float("nan"),
                )
            )
    return found


def attraction_numbers(rollouts: list) -> dict:
    """The rollouts' summary, JSON-ready: how many, the shares at rest and come back, the median
    tick of rest, the median distances to y_T (u) at start and end, and the median and largest
    undershoot of f(y_T) (in the demos' falls)."""
    rest_ticks = [r.ticks for r in rollouts if r.at_rest]
    undershoots = np.array([r.undershoot for r in rollouts])
    return {
        "rollouts": len(rollouts),
        "at_rest": float(np.mean([r.at_rest for r in rollouts])),
        "came_back": float(np.mean([r.came_back for r in rollouts])),
        "rest_tick_median": float(np.median(rest_ticks)) if rest_ticks else float("nan"),
        "start_distance_median": float(np.median([r.start_distance for r in rollouts])),
        "end_distance_median": float(np.median([r.end_distance for r in rollouts])),
        "undershoot_median": float(np.nanmedian(undershoots)),
        "undershoot_max": float(np.nanmax(undershoots)),
    }


def end_measures(
    model: ValueFunction,
    dataset: Dataset,
    robot: RobotModel,
    count: int = 60,
    sigma: float = SIGMA,
    seed: int = 0,
) -> dict:
    """Whether f has its minimum where the demonstrations end: "end_samples_above", the share of
    count noisy samples around each demonstration's last state (Gaussian of sigma per joint within
    the limits, collision-free with the demonstration's end scene), over all demonstrations, where
    f is above f(y_T); "end_gradient_ratio", the median over the demonstrations of
    |grad_q (f o phi)| at y_T over its median along the demonstration."""
    features = FeatureMap(dataset.definition, robot)
    rng = np.random.default_rng(seed)
    above, total, ratios = 0, 0, []
    for demo in dataset.demos:
        collision = SceneCollision(robot, demo.situation, SAMPLE_CONTACT_TOLERANCE)
        poses = demo.object_poses[-1]
        drawn = draws_around(
            rng,
            demo.q[-1],
            count,
            sigma,
            robot,
            lambda q, check=collision, scene=poses: check.collision_free(q, scene),
        )
        if len(drawn):
            values = model.value(features.batch(drawn, poses))
            above += int(np.sum(values > model.value(demo.y[-1])))
            total += len(drawn)
        norms = [
            np.linalg.norm(model.gradient(y)[1] @ jacobian)
            for y, jacobian in zip(demo.y, demo.jacobians)
        ]
        ratios.append(norms[-1] / max(float(np.median(norms)), 1e-12))
    return {
        "end_samples_above": above / total if total else float("nan"),
        "end_gradient_ratio": float(np.median(ratios)),
    }
