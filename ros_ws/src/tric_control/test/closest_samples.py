"""Hand-made tric_sim.world.proximity.Closest results for the limits' tests."""

import numpy as np

from tric_sim.world.proximity import Closest

#: The scene bodies of every hand-made Closest (pairs name them by index; -1: within the robot).
BODY_NAMES = ("table", "object", "lid")


def hand_made(distances, bodies, hand, rows=None, aways=None, body_rotations=None) -> Closest:
    """A Closest of pairs with the given distances (m), bodies (indices into BODY_NAMES, -1: within
    the robot) and hands; unit rows along joint k for pair k (of 14 joints) and aways along +z
    unless given; every body upright unless body_rotations (3, 3, 3) is given."""
    k = len(distances)
    return Closest(
        np.arange(k),
        np.array(distances, float),
        np.eye(k, 14) if rows is None else np.array(rows, float),
        np.tile([0.0, 0.0, 1.0], (k, 1)) if aways is None else np.array(aways, float),
        np.array(bodies),
        np.array(hand),
        [f"pair_{i}" for i in range(k)],
        BODY_NAMES,
        np.tile(np.eye(3), (len(BODY_NAMES), 1, 1)) if body_rotations is None else body_rotations,
    )
