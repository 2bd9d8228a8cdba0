"""The soft side of contact: a cost that pushes the hand back from a body it may press, within a
cushion of the body's surface. ROS-free. Units: m."""

import numpy as np

from tric_control.limits.base import Limit, StepState
from tric_control.limits.contact_rules import ContactRules


class SoftContact(Limit):
    """For each pair of state.closest that holds its body's contact (contacts: {scene body name:
    tric_sim.scene.Contact}, the task's) and is closer than the contact's cushion c: the cost
    w (d + r dq - c)^2 with w = cushion_weight / |r|^2 (r: the distance's row), a spring of stiffness
    cushion_weight in the step's metric that pushes the hand back to the cushion. Contacts without a
    cushion add nothing."""

    def __init__(self, contacts: dict):
        self.rules = ContactRules(contacts)

    def add_cost(self, state: StepState, hessian: np.ndarray, linear: np.ndarray) -> None:
        closest = state.closest
        if not len(closest):
            return
        rules = self.rules
        held = rules.held(closest)
        if not held.any():
            return
        bodies = closest.bodies
        cushion = rules.cushion[bodies]
        for k in np.flatnonzero(held & (cushion > 0.0) & (closest.distances < cushion)).tolist():
            row, distance, body = closest.rows[k], closest.distances[k], bodies[k]
            weight = rules.cushion_weight[body] / max(row @ row, 1e-9)
            hessian += 2.0 * weight * np.outer(row, row)
            linear += 2.0 * weight * (distance - rules.cushion[body]) * row
