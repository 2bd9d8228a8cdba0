"""A situation's validation (tric_sim.world.situation): every bad field refused with the reason."""

import dataclasses
import math

import pytest

from tric_sim.world import situations as S


@pytest.mark.parametrize(
    "change, message",
    [
        ({"task": "juggle"}, "unknown task"),
        ({"object_kind": "box"}, "does not fit task"),
        ({"object_dimensions": (0.04, 0.1)}, "must have 1 value"),
        ({"object_dimensions": (-0.04,)}, "positive"),
        ({"object_position": (math.nan, 0.0, 0.3)}, "non-finite"),
        ({"object_position": (5.0, 0.0, 0.3)}, "outside the workspace"),
        ({"object_orientation": (0.0, 0.0, 0.0, 2.0)}, "unit quaternion"),
        ({"initial_joint_positions": (0.0,) * 3}, "must have 14"),
        ({"name": ""}, "non-empty name"),
    ],
)
def test_bad_situations_are_refused(change, message):
    good = S.sphere("s", (0.6, 0.0, 0.3))
    with pytest.raises(ValueError, match=message):
        dataclasses.replace(good, **change).validate()
