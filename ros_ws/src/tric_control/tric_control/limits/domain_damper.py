"""The learned model's domain as velocity dampers: features kept within the range the model was
trained on. ROS-free. Units: those of the features' scaled values (1), s."""

import numpy as np

from tric_control.limits.base import UNBOUNDED_BELOW, Limit, StepState, damper_bounds


class DomainDamper(Limit):
    """A learned value function is only known where it was trained: without bounds its linear part
    extrapolates and the controller drives the robot into configurations never demonstrated (fingers
    bent backwards) where f keeps falling. The objective names the features nearest the bounds of
    their range (Objective.domain_rows: the gradients of their margins in q, domain_margins, >= 0
    inside, domain_names); for the first `rows` of them, du/dq dq >= -damping * margin. A feature is
    active (named "feature_range:<feature>") when its row binds the step."""

    def __init__(self, rows: int, damping: float):
        if not (rows >= 0 and 0 < damping <= 1):
            raise ValueError(
                f"the domain damper needs rows >= 0 and damping in (0, 1], got {rows}, {damping}"
            )
        self.rows, self.damping = rows, damping
        self._used = 0

    def constrain(self, state: StepState, rows: np.ndarray, lower: np.ndarray) -> None:
        objective = state.objective
        used = self._used = min(len(objective.domain_margins), self.rows)
        rows[used:] = 0.0
        lower[used:] = UNBOUNDED_BELOW
        if used:
            rows[:used] = objective.domain_rows[:used]
            damper_bounds(
                rows[:used],
                objective.domain_margins[:used],
                self.damping,
                state.max_step,
                lower[:used],
            )

    def active(self, state: StepState, step: np.ndarray, binding: np.ndarray) -> list:
        names = state.objective.domain_names
        return [f"feature_range:{names[k]}" for k in np.flatnonzero(binding[: self._used])]
