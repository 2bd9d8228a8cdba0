"""The joints' position limits, kept with a margin, and their per-tick step bound (velocity limit
times control period) as the box of the step. ROS-free. Units: rad (m for a prismatic joint), s."""

import numpy as np

from tric_control.limits.base import Limit, StepState

#: Below this, a bound counts as reached (rad).
REACHED = 1e-9


class JointLimits(Limit):
    """The box low <= dq <= high of a step from the reference: within [lower + margin, upper -
    margin] (the robot's limits; margin one for all joints or (n,), rad or m as each joint moves)
    and within the step bound max_step (n,) of each joint. It always holds dq = 0 (from a
    reference outside the margin, the step may stay there but not go further). A joint is active
    where the step sits on a position bound tighter than its step bound."""

    def __init__(self, lower: np.ndarray, upper: np.ndarray, joint_names, margin):
        if not np.all(np.asarray(margin) >= 0):
            raise ValueError(f"the joint limit margin must be >= 0, got {margin!r}")
        self.lowest, self.highest = np.asarray(lower) + margin, np.asarray(upper) - margin
        self.joint_names = list(joint_names)
        self._low, self._high = np.empty(len(self.lowest)), np.empty(len(self.lowest))
        # whether a position bound was tighter than the step bound at the last tick
        self._near = False

    def bound(self, state: StepState, low: np.ndarray, high: np.ndarray) -> None:
        mine_low, mine_high, max_step = self._low, self._high, state.max_step
        np.subtract(self.lowest, state.reference, out=mine_low)
        np.subtract(self.highest, state.reference, out=mine_high)
        # a position bound is tighter than the step bound: the joint is within one step of it
        self._near = bool(
            np.count_nonzero(mine_low > -max_step) or np.count_nonzero(mine_high < max_step)
        )
        if self._near:
            np.maximum(mine_low, -max_step, out=mine_low)
            np.minimum(mine_high, max_step, out=mine_high)
            np.maximum(low, np.minimum(mine_low, 0.0, out=mine_low), out=low)
            np.minimum(high, np.maximum(mine_high, 0.0, out=mine_high), out=high)
        else:
            np.maximum(low, -max_step, out=low)
            np.minimum(high, max_step, out=high)

    def active(self, state: StepState, step: np.ndarray, binding: np.ndarray) -> list:
        if not self._near:
            return []
        low, high, max_step = state.low, state.high, state.max_step
        hit = (step <= low + REACHED) & (low > -max_step + REACHED) | (step >= high - REACHED) & (
            high < max_step - REACHED
        )
        return [f"joint_limit:{self.joint_names[i]}" for i in np.flatnonzero(hit)]
