"""Hand-made value functions for the controller's tests: f of the palm's distance to a sphere."""

import numpy as np

from tric_learning.features import FeatureDefinition
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.world import situations

#: The sphere the palm approaches, and its pose for the controller.
SPHERE = situations.sphere("sphere", (0.55, 0.0, 0.45))
SPHERE_POSES = {"object": (SPHERE.object_position, SPHERE.object_orientation)}


def palm_minimum_value(definition: FeatureDefinition) -> ValueFunction:
    """f(u) = u - sigmoid(10 (u + 0.1)) of the palm's scaled distance to the object u = (d - 0.25)
    / 0.75: its minimum at u* about 0.106 (f about -0.78, the palm 33 cm from the object)."""
    kept = np.array([definition.feature_names.index("d[palm,object]")])
    return ValueFunction(
        Scaling(kept, np.array([0.25]), np.array([1.0]), definition.size),
        np.array([[10.0]]),
        np.array([-1.0]),
        np.array([1.0]),
        np.array([1.0]),
    )
