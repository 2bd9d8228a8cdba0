"""Selection scores: how closely a candidate's rollouts from its demonstrations' starts did what
the demonstrations did; lower is better. ROS-free.

Each score is a mean over the demonstrations of a per-rollout error; a rollout whose controller
failed counts as the worst (infinite error). The demonstration-only scores:

- "landmarks" (the default): the distances between each object landmark and every other landmark
  (the feature definition's d_ij of every pair that holds an object: the hand's landmarks to the
  object, and the lid to its box) at the rollout's end against the demonstration's end, each error
  divided by how far the demonstrations move that distance (the mean of |d_ij(start) - d_ij(end)|
  over them): 1 is an error as large as the demonstrated motion;
- "features": the same over every feature of the definition;
- "joints": the distance between the end joint positions, rad;
- "value": |f(end) - f(y_T)| over the demonstrations' mean fall of f.

The judge's (they read the task's hidden metrics, which a user recording a new task by hand does
not have; studies compare with them): "judge", the grasp cost (1 for a run that failed), or for a
box minus the lid's angle in rad; "successes", minus the count of judged successes (for a grasp a
good grasp that held in the lift test): the yes/no label a user watching the rollouts would give.
"""

import math

import numpy as np

from tric_learning.features import FeatureDefinition
from tric_learning.training.dataset import Dataset
from tric_sim.physics.metrics import GOOD_GRASP

#: The least demonstrated motion a distance's error is divided by, m: a distance the demonstrations
#: keep fixed (the box to the robot's base) weighs as a 1 cm motion.
LEAST_MOTION = 0.01


def object_pair_distances(definition: FeatureDefinition) -> np.ndarray:
    """Indices into the features of the distances d_ij (i < j) of every landmark pair that holds
    an object landmark ("object/..." sources)."""
    objects = {
        k for k, source in enumerate(definition.landmark_sources) if source.startswith("object/")
    }
    return np.array(
        [
            4 * index + 3
            for index, (i, j) in enumerate(definition.pairs)
            if i < j and (i in objects or j in objects)
        ],
        dtype=int,
    )


def demonstrated_motion(dataset: Dataset) -> np.ndarray:
    """(d,) the mean over the demonstrations of each feature's |y(start) - y(end)|, at least
    LEAST_MOTION."""
    moved = np.mean([np.abs(demo.y[0] - demo.y[-1]) for demo in dataset.demos], axis=0)
    return np.maximum(moved, LEAST_MOTION)


def per_rollout_errors(name: str, rollouts: list, dataset: Dataset, model=None) -> np.ndarray:
    """(demos,) the error of each rollout (in the dataset's order) by the score name (see the
    module docstring); model: the candidate's ValueFunction (score "value" only)."""
    demos = dataset.demos
    if len(rollouts) != len(demos) or any(r.demo != d.name for r, d in zip(rollouts, demos)):
        raise ValueError("the rollouts must be those of the dataset's demonstrations, in order")
    if name in ("landmarks", "features"):
        motion = demonstrated_motion(dataset)
        index = (
            object_pair_distances(dataset.definition)
            if name == "landmarks"
            else np.arange(dataset.definition.size)
        )
        errors = [
            np.mean(np.abs(r.y[index] - d.y[-1][index]) / motion[index])
            for r, d in zip(rollouts, demos)
        ]
    elif name == "joints":
        errors = [np.linalg.norm(r.q - d.q[-1]) for r, d in zip(rollouts, demos)]
    elif name == "value":
        if model is None:
            raise ValueError("the score 'value' needs the candidate's value function")
        fall = np.mean([model.value(d.y[0]) - model.value(d.y[-1]) for d in demos])
        errors = [
            abs(r.value_end - float(model.value(d.y[-1]))) / max(fall, 1e-12)
            for r, d in zip(rollouts, demos)
        ]
    elif name == "judge":
        errors = [_judged_cost(r) for r in rollouts]
    elif name == "successes":
        errors = [-float(_judged_success(r)) for r in rollouts]
    else:
        raise ValueError(f"unknown selection score '{name}'")
    values = np.array(errors, dtype=float)
    failed = np.array([r.failed for r in rollouts]) | ~np.isfinite(values)
    values[failed] = 0.0 if name == "successes" else math.inf
    return values


def score(name: str, rollouts: list, dataset: Dataset, model=None) -> float:
    """The candidate's score: the mean of per_rollout_errors (for "successes", minus the count of
    successes)."""
    errors = per_rollout_errors(name, rollouts, dataset, model)
    return float(np.sum(errors)) if name == "successes" else float(np.mean(errors))


def _judged_cost(rollout) -> float:
    """The hidden metrics' cost of a rollout: the grasp cost (1 if none), or minus the lid's
    angle."""
    judged = rollout.judged
    angle = judged.get("lid_angle")
    if angle is not None and math.isfinite(angle):
        return -float(angle)
    cost = judged.get("grasp_cost")
    return float(cost) if cost is not None and math.isfinite(cost) else 1.0


def _judged_success(rollout) -> bool:
    """The hidden metrics' verdict: a good grasp that held in the lift test, or an opened box."""
    judged = rollout.judged
    cost = judged.get("grasp_cost")
    if cost is not None and math.isfinite(cost):
        return bool(cost < GOOD_GRASP and judged.get("lift_passed") is True)
    return bool(judged.get("success"))
