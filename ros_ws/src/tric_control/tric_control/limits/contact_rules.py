"""A task's contacts (tric_sim.scene.Contact by scene body name) applied to collision pairs: which
pairs of the hand with a body it may press hold their leave at the moment. ROS-free. Units: m."""

import numpy as np


class ContactRules:
    """The contacts {scene body name: Contact} of a task, read per tick against the pairs of a
    tric_sim.collision.Closest. A pair holds its body's contact when its robot side is the hand and,
    for a contact with a side, the hand is on that side of the body: the direction in which the hand
    moves away from the body has a non-negative component along the side (body frame)."""

    def __init__(self, contacts: dict):
        self.contacts = dict(contacts)
        self._names = None   # the body names the per-body tables below were made for

    def _tables(self, body_names: tuple) -> None:
        """Per-body tables for the scene's bodies, plus a last entry (index -1) for pairs within the
        robot, which hold no contact."""
        self._names = body_names
        rules = [self.contacts.get(name) for name in body_names] + [None]
        self.allowed = np.array([rule is not None for rule in rules])
        self.depth = np.array([rule.depth if rule else 0.0 for rule in rules])
        self.cushion = np.array([rule.cushion if rule else 0.0 for rule in rules])
        self.cushion_weight = np.array([rule.cushion_weight if rule else 0.0 for rule in rules])
        sides = [rule.side if rule and rule.side is not None else (0.0, 0.0, 0.0) for rule in rules]
        self.sided = np.array([bool(rule and rule.side is not None) for rule in rules])
        self.sides = np.array(sides[:-1], dtype=float).reshape(-1, 3)
        self._world_sides = np.zeros((len(rules), 3))

    def held(self, closest) -> np.ndarray:
        """(k,) bool: which pairs of closest hold their body's contact now."""
        if closest.body_names is not self._names:
            self._tables(closest.body_names)
        bodies = closest.bodies
        held = closest.hand & self.allowed[bodies]
        if self.sided.any() and held.any():
            np.einsum("bij,bj->bi", closest.body_rotations, self.sides, out=self._world_sides[:-1])
            facing = np.einsum("ki,ki->k", closest.aways, self._world_sides[bodies])
            held &= ~self.sided[bodies] | (facing >= 0.0)
        return held
