"""Leaving a stall: a rest far above where the task is done, left by a random walk of the arm and a
new descent (docs/decisions/stall-escape.md). ROS-free. Units: rad, ticks, and f's own.

TRIC's controller descends f and comes to rest at a minimum of f (Sec. 5.4). Some minima lie
halfway, far above where the model's own rollouts from its demonstrations' starts came to rest
(the selection's, tric_control.selection: the model file's "done_value", their median f at rest).
A rest with f above done_value by more than STALL_SHARE of the demonstrations' mean fall (500
delta, Sec. 5.2.3) is a stall, not the task done. With a StallEscape the episode runner
(tric_control.episode_runner) then walks the arm to a random nearby configuration, each arm joint
moved by a draw from [-rad, rad], through the same motion-rate controller (its constraints, the
collision damper among them, still hold; only its objective follows the walk), and descends f
again from there; at most `escapes` times an episode. It is the random walk that randomized
potential-field planners use to leave local minima (Barraquand and Latombe, 1991).
"""

from dataclasses import dataclass

import numpy as np

from tric_control.objectives.base import Objective
from tric_learning.training.value import TICKS_PER_DEMO

#: A rest is a stall when f is above the model's done_value by more than this share of the
#: demonstrations' mean fall (TICKS_PER_DEMO delta). Chosen from the box candidates' rollouts
#: from their training starts (docs/decisions/stall-escape.md).
STALL_SHARE = 0.3
#: The walks an episode may take by default (the controller node's stall_escapes).
DEFAULT_ESCAPES = 3
#: The walk's reach per arm joint, rad (a draw from [-ESCAPE_RAD, ESCAPE_RAD] for each).
ESCAPE_RAD = 0.3
#: A walk ends when every joint is within WALK_REACHED_RAD of its goal, or after WALK_TICKS.
WALK_TICKS = 100
WALK_REACHED_RAD = 0.02
#: The walk's weight on following its step, relative to the controller's |dq|^2.
WALK_WEIGHT = 1e3


@dataclass(frozen=True)
class StallEscape:
    """The escape's settings: escapes (walks at most per episode, >= 0; 0: none, the paper's
    controller), rad (each arm joint's reach, rad, > 0) and seed (of the walks' draws, >= 0: an
    episode's walks are the same for the same seed)."""

    escapes: int = 0
    rad: float = ESCAPE_RAD
    seed: int = 0

    def __post_init__(self):
        if not (isinstance(self.escapes, int) and self.escapes >= 0):
            raise ValueError(f"the stall escapes must be a count >= 0, not {self.escapes!r}")
        if not (np.isfinite(self.rad) and self.rad > 0):
            raise ValueError(f"the escape's reach must be finite and > 0 rad, not {self.rad!r}")
        if not (isinstance(self.seed, int) and self.seed >= 0):
            raise ValueError(f"the escape's seed must be an integer >= 0, not {self.seed!r}")

    def goal(self, q: np.ndarray, arm, lower: np.ndarray, upper: np.ndarray, walk: int):
        """The walk's goal (n,) from q (n,): the arm joints (indices arm) each moved by a draw from
        [-rad, rad] (the episode's walk-th draw), within [lower, upper]."""
        goal = np.array(q, dtype=float)
        draws = np.random.default_rng([self.seed, walk]).uniform(-self.rad, self.rad, len(arm))
        goal[arm] += draws
        return np.clip(goal, lower, upper)


def stalled(objective, value: float) -> bool:
    """Whether a rest with f at value is a stall for objective: f above its done_value by more
    than STALL_SHARE of TICKS_PER_DEMO delta. False for an objective without a done_value (a model
    chosen by no selection, an ensemble, DPL)."""
    done = getattr(objective, "done_value", None)
    if done is None:
        return False
    return bool(value > done + STALL_SHARE * TICKS_PER_DEMO * objective.delta)


class WalkObjective:
    """The objective of a walk: WALK_WEIGHT |dq - s|^2, s the step toward goal (n,) bounded by
    max_step (n,) per joint; inner's value, gradient and domain rows are kept (the status, and
    the controller's constraints, read them). done_value None: a walk is never a stall."""

    done_value = None
    rest = None

    def __init__(self, inner, goal: np.ndarray, max_step: np.ndarray):
        self.inner, self.goal, self.max_step = inner, np.asarray(goal, dtype=float), max_step
        self.delta = inner.delta
        # the same every tick (the controller only reads it)
        self._hessian = 2.0 * WALK_WEIGHT * np.eye(len(self.goal))

    def reached(self, q: np.ndarray) -> bool:
        """Whether every joint of q (n,) is within WALK_REACHED_RAD of the goal."""
        return bool(np.max(np.abs(np.asarray(q, dtype=float) - self.goal)) < WALK_REACHED_RAD)

    def __call__(self, q, object_poses) -> Objective:
        model = self.inner(q, object_poses)
        step = np.clip(self.goal - np.asarray(q, dtype=float), -self.max_step, self.max_step)
        model.hessian = self._hessian
        model.linear = -2.0 * WALK_WEIGHT * step
        return model
