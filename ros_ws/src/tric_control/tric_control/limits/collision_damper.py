"""Collision avoidance as velocity dampers on the closest pairs of robot geometries and scene bodies
(or other robot geometries). ROS-free. Units: m, s."""

from typing import cast

import numpy as np

from tric_control.limits.base import UNBOUNDED_BELOW, Limit, StepState, damper_bounds
from tric_control.limits.contact_rules import ContactRules


class CollisionDamper(Limit):
    """For the `rows` closest pairs (state.closest), n^T J dq >= -damping * (d - safety): no pair
    closes faster than the fraction damping of its remaining margin per tick. The safety distance
    (m) is `safety` against the scene, `self_safety` between the robot's own links, and -depth for
    the hand against a body whose contact (the task's tric_sim.world.scene.Contact, read through
    rules) it holds at the moment: there the hand may press that deep. A pair is active (named
    "<robot geometry>/<other>") when its row binds the step."""

    def __init__(
        self, rules: ContactRules, rows: int, safety: float, self_safety: float, damping: float
    ):
        if not (rows >= 0 and 0 < damping <= 1):
            raise ValueError(
                f"the collision damper needs rows >= 0 and damping in (0, 1], got {rows}, {damping}"
            )
        self.rules = rules
        self.rows, self.safety, self.self_safety, self.damping = rows, safety, self_safety, damping
        self._used = 0
        self._margins = np.empty(rows)
        self._names: tuple | None = None
        self._safety: np.ndarray | None = None

    def constrain(self, state: StepState, rows: np.ndarray, lower: np.ndarray) -> None:
        closest = state.closest
        used = self._used = min(len(closest), self.rows)
        rows[used:] = 0.0
        lower[used:] = UNBOUNDED_BELOW
        if not used:
            return
        rules, bodies, distances = self.rules, closest.bodies[:used], closest.distances[:used]
        # safety by body, the last for pairs within the robot
        if closest.body_names is not self._names:
            self._names = closest.body_names
            self._safety = np.array([self.safety] * len(self._names) + [self.self_safety])
        margins = self._margins[:used]
        safety = cast(np.ndarray, self._safety)  # made for these body names
        np.subtract(distances, safety.take(bodies), out=margins)
        held = rules.held(closest)[:used]
        if np.count_nonzero(held):
            np.add(distances, rules.depth.take(bodies), out=margins, where=held)
        rows[:used] = closest.rows[:used]
        damper_bounds(rows[:used], margins, self.damping, state.max_step, lower[:used])

    def active(self, state: StepState, step: np.ndarray, binding: np.ndarray) -> list:
        return state.closest.names(np.flatnonzero(binding[: self._used])) if self._used else []
