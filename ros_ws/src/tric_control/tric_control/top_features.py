"""What the controller shows of its model each tick: the top features by score, with their current
values and gradients (tric_msgs/ControllerStatus feature_* fields). ROS-free.

The order is the paper's feature score s(y) = |W1^T| |W2| + |W3| (Sec. 5.5.1), the same as
tric-analyze's Fig. 16; values are the scaled features u in [0, 1] over the training data and
gradients are df/du, both from the objective's latest evaluation (no extra computation per tick).
"""

from typing import cast

import numpy as np

from tric_control.objectives import ValueObjective

#: How many features a status carries.
TOP_FEATURES = 10


class TopFeatures:
    """The `count` highest-scored features of an objective's model; none for objectives without a
    value function (DPL)."""

    def __init__(self, objective, count: int = TOP_FEATURES):
        self.objective = objective if isinstance(objective, ValueObjective) else None
        if self.objective is None:
            self.indices, self.names = np.zeros(0, dtype=int), []
            return
        scores = objective.value_function.scores()
        self.indices = np.argsort(-scores, kind="stable")[:count]
        self.names = [objective.kept_names[k] for k in self.indices]

    def read(self) -> tuple:
        """(names, values u, gradients df/du) at the objective's latest call, as lists; empty lists
        before the first call and for objectives without a value function."""
        if self.objective is None or self.objective.scaled_features is None:
            return [], [], []
        return (
            list(self.names),
            self.objective.scaled_features[self.indices].tolist(),
            # set with scaled_features
            cast(np.ndarray, self.objective.value_gradient)[self.indices].tolist(),
        )
