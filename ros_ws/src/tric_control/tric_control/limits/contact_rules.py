"""A task's contacts (tric_sim.world.scene.Contact by scene body name) applied to collision
pairs: which pairs of the hand with a body it may press hold their leave at the moment. ROS-free.
Units: m."""

from typing import cast

import numpy as np


class ContactRules:
    """The contacts {scene body name: Contact} of a task, read per tick against the pairs of a
    tric_sim.world.proximity.Closest. A pair holds its body's contact when its robot side is the
    hand and, for a contact with a side, the hand is on that side of the body: the direction in
    which the hand moves away from the body has a non-negative component along the side (body
    frame).

    Limits that share one ContactRules (CollisionDamper, SoftContact) share its answer for a tick.
    Per-body tables (for the bodies of the last Closest seen; entry -1: pairs within the robot,
    which hold no contact): allowed, depth, cushion (-inf: none) and cushion_weight (B + 1,)."""

    def __init__(self, contacts: dict):
        self.contacts = dict(contacts)
        self.widest_cushion = max((rule.cushion for rule in self.contacts.values()), default=0.0)
        self._names: tuple | None = None  # the body names the tables were made for
        self._closest = None  # the Closest of the last answer
        self._held: np.ndarray | None = None

    def _tables(self, body_names: tuple) -> None:
        self._names = body_names
        rules = [self.contacts.get(name) for name in body_names] + [None]
        self.allowed = np.array([rule is not None for rule in rules])
        self.depth = np.array([rule.depth if rule else 0.0 for rule in rules])
        self.cushion = np.array(
            [rule.cushion if rule and rule.cushion > 0 else -np.inf for rule in rules]
        )
        self.cushion_weight = np.array([rule.cushion_weight if rule else 0.0 for rule in rules])
        self.sided = np.array([bool(rule and rule.side is not None) for rule in rules])
        self._any_sided = bool(self.sided.any())
        self._sides = np.array(
            [
                rule.side if rule and rule.side is not None else (0.0, 0.0, 0.0)
                for rule in rules[:-1]
            ],
            dtype=float,
        ).reshape(-1, 3)
        self._world_sides = np.zeros((len(rules), 3))

    def held(self, closest) -> np.ndarray:
        """(k,) bool: which pairs of closest hold their body's contact now."""
        if closest is self._closest:
            return cast(np.ndarray, self._held)  # the answer for this closest
        if closest.body_names is not self._names:
            self._tables(closest.body_names)
        bodies = closest.bodies
        held = closest.hand & self.allowed.take(bodies)
        if self._any_sided and np.count_nonzero(held):
            np.einsum("bij,bj->bi", closest.body_rotations, self._sides, out=self._world_sides[:-1])
            facing = np.einsum("ki,ki->k", closest.aways, self._world_sides.take(bodies, axis=0))
            held &= ~self.sided.take(bodies) | (facing >= 0.0)
        self._closest, self._held = closest, held
        return held
