"""The controller's collision prior along the demonstrations: Fig. 14b (the hand's smallest
distance to the body it may touch, and how many hand-body pairs are within the controller's
influence distance, by step)."""

import pathlib

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from tric_learning.analysis.drawing import light_and_mean
from tric_learning.analysis.measures import CONTROLLER_INFLUENCE
from tric_sim.tools.output_files import atomic_path


def plot_collision_prior(
    distances: np.ndarray,
    counts: np.ndarray,
    role: str,
    geometries: int,
    path: pathlib.Path,
    influence: float = CONTROLLER_INFLUENCE,
) -> pathlib.Path:
    """Fig. 14b: the hand's smallest distance to the body it may touch (N, T) and the number of
    hand-body pairs within influence (N, T) by step, each demo light and their mean bold."""
    body = {"target": "the grasp target", "lid": "the lid"}.get(role, role)
    figure = Figure(figsize=(8.0, 6.5), layout="constrained")
    FigureCanvasAgg(figure)
    distance_axes, count_axes = figure.subplots(2, 1, sharex=True)
    light_and_mean(
        distance_axes,
        distances,
        "tab:blue",
        f"mean over {len(distances)} demonstrations (light: each)",
    )
    distance_axes.axhline(
        influence,
        color="tab:orange",
        linestyle="--",
        linewidth=1,
        label=f"controller's influence distance {influence * 100:.0f} cm",
    )
    distance_axes.axhline(0.0, color="grey", linewidth=1)
    distance_axes.set_ylabel("smallest distance (m)")
    distance_axes.set_title(f"the hand (palm and finger links) and {body}")
    distance_axes.grid(alpha=0.3)
    distance_axes.legend()
    light_and_mean(count_axes, counts, "tab:purple", "mean")
    count_axes.set_ylim(-0.3, geometries + 0.3)
    count_axes.set_xlabel("step t")
    count_axes.set_ylabel(f"hand-{role} pairs within {influence * 100:.0f} cm\n(of {geometries})")
    count_axes.grid(alpha=0.3)
    count_axes.legend()
    figure.suptitle("the controller's collision prior along the demonstrations (paper Fig. 14b)")
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=120)
    return path
