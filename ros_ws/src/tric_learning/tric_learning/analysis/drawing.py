"""Drawing pieces the analysis figures share."""

import numpy as np

from tric_learning.analysis.measures import mean_over_demos


def light_and_mean(axes, values: np.ndarray, colour: str, label: str):
    """Each row of values (N, T) as a light line and their mean over the rows as a bold one."""
    steps = np.arange(values.shape[1])
    for row in values:
        axes.plot(steps, row, color=colour, alpha=0.2, linewidth=0.8)
    axes.plot(steps, mean_over_demos(values), color=colour, linewidth=2.2, label=label)
