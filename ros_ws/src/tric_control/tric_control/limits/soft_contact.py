"""The soft side of contact: a cost that pushes the hand back from a body it may press, within a
cushion of the body's surface. ROS-free. Units: m."""

import numpy as np

from tric_control.limits.base import Limit, StepState
from tric_control.limits.contact_rules import ContactRules


class SoftContact(Limit):
    """For each pair of state.closest that holds its body's contact (the task's
    tric_sim.world.scene.Contact) and is closer than the contact's cushion c: the cost
    w (d + r dq - c)^2 with w = cushion_weight / |r|^2 (r: the distance's row), a spring of
    stiffness cushion_weight in the step's metric that pushes the hand back to the cushion. Contacts
    without a cushion add nothing (rules: tric_control.limits.ContactRules)."""

    def __init__(self, rules: ContactRules):
        self.rules = rules

    def add_cost(self, state: StepState, hessian: np.ndarray, linear: np.ndarray) -> None:
        closest, rules = state.closest, self.rules
        if not (len(closest) and closest.distances[0] < rules.widest_cushion):
            return
        held = rules.held(closest)
        bodies = closest.bodies
        pressing = np.flatnonzero(held & (closest.distances < rules.cushion.take(bodies)))
        if not len(pressing):
            return
        # (m, n), (m,)
        rows, bodies = closest.rows.take(pressing, axis=0), bodies.take(pressing)
        weights = (
            2.0
            * rules.cushion_weight.take(bodies)
            / np.maximum(np.einsum("kn,kn->k", rows, rows), 1e-9)
        )
        hessian += (rows.T * weights) @ rows
        linear += (weights * (closest.distances.take(pressing) - rules.cushion.take(bodies))) @ rows
