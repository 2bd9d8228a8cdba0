"""What every piece of the motion-rate step's QP has in common: the state it sees at a tick and the
ways it may shape the step. ROS-free.

The step dq (n,) solves

    min 1/2 dq^T H dq + c^T dq    s.t.  lower <= C dq,   low <= dq <= high

and each limit adds to it in one or more ways: a cost (add_cost: terms added to H and c in place), a
box (bound: low and high tightened in place), inequality rows (constrain: a fixed number of rows of
C and of lower, written in place; rows it has no use for this tick are padded with 0 >=
UNBOUNDED_BELOW, so that the QP keeps its size and proxsuite its workspace), and names for what
binds the step (active). Units: rad, m, s.
"""

from dataclasses import dataclass
from typing import Any

import numpy as np

#: The lower bound of a padded inequality row: it constrains nothing.
UNBOUNDED_BELOW = -1e20


@dataclass
class StepState:
    """What the limits see at one tick.

    q: the measured joint positions (n,), rad.
    reference: the command the step starts from (n,), rad.
    max_step: the per-tick step bound of each joint (n,), rad (velocity limit times period).
    objective: the objective's model at q (tric_control.objectives.Objective).
    closest: the collision pairs near q, closest first (tric_sim.world.proximity.Closest).
    low, high: the step's box bounds (n,) once every limit has tightened them.
    Each is None until the step sets it (a test sets only what the limit it tries reads): typed Any.
    """

    q: Any = None
    reference: Any = None
    max_step: Any = None
    objective: Any = None
    closest: Any = None
    low: Any = None
    high: Any = None


class Limit:
    """A piece of the step's QP. Subclasses override what they use; rows says how many inequality
    rows constrain() writes (the same every tick)."""

    rows = 0

    def add_cost(self, state: StepState, hessian: np.ndarray, linear: np.ndarray) -> None:
        """Add this limit's quadratic cost in dq to hessian (n, n) and linear (n,), in place."""

    def bound(self, state: StepState, low: np.ndarray, high: np.ndarray) -> None:
        """Tighten the box bounds low, high (n,) of the step in place (they start at -inf, inf)."""

    def constrain(self, state: StepState, rows: np.ndarray, lower: np.ndarray) -> None:
        """Write this limit's inequality rows (self.rows, n) and their lower bounds (self.rows,)
        (views into the QP's), lower <= rows @ dq."""

    def active(self, state: StepState, step: np.ndarray, binding: np.ndarray) -> list:
        """Names of what binds the solved step (n,); binding (self.rows,) tells which of this
        limit's rows hold with equality."""
        return []


def damper_bounds(
    rows: np.ndarray, margins: np.ndarray, gain: float, max_step: np.ndarray, out: np.ndarray
) -> None:
    """Velocity dampers rows @ dq >= -gain * margin for margins (k,) that must stay >= 0, with rows
    (k, n) their gradients: each margin may fall by at most the fraction gain of itself per tick.
    A damper never asks for more than half of what a step within max_step (n,) can give. Writes the
    lower bounds (k,) into out."""
    np.minimum(-gain * margins, (0.5 * np.abs(rows)) @ max_step, out=out)
