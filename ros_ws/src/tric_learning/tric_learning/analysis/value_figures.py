"""The value function along the demonstrations: Fig. 13 (f along every demonstration over
normalized time) and Fig. 14a (L_g's cosine between f's gradient and each demonstrated step)."""

import pathlib

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from tric_learning.analysis.measures import mean_over_demos
from tric_sim.tools.output_files import atomic_path


def plot_values(curves: list, names: list, path: pathlib.Path) -> pathlib.Path:
    """Fig. 13: each demo's f over normalized time, coloured by demo index."""
    figure = Figure(figsize=(7.0, 4.5), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    colours = matplotlib.colormaps["viridis"].resampled(max(len(curves), 2))
    for k, values in enumerate(curves):
        axes.plot(
            np.linspace(0.0, 1.0, len(values)),
            values,
            color=colours(k),
            linewidth=1.2,
            marker=".",
            markersize=3,
        )
    axes.set_xlabel("normalized time t / (T - 1)")
    axes.set_ylabel("value f(y_t)")
    axes.set_title(
        f"f along {len(curves)} demonstrations ({names[0]} ... {names[-1]})"
        if len(names) > 1
        else f"f along {names[0]}"
    )
    axes.grid(alpha=0.3)
    mappable = ScalarMappable(cmap=colours, norm=Normalize(0, max(len(curves) - 1, 1)))
    figure.colorbar(mappable, ax=axes, label="demonstration")
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=120)
    return path


def plot_cosines(cosines: np.ndarray, moving: np.ndarray, path: pathlib.Path) -> pathlib.Path:
    """Fig. 14a: the cosines (N, T - 1) of every demo and step as a heatmap (blue: -1, f falls along
    the step), and their mean over the demos by step, beside the same over the moving steps only
    (moving: the cosines with NaN where a step is too short to have a direction, (N, T - 1))."""
    figure = Figure(figsize=(8.0, 6.5), layout="constrained")
    FigureCanvasAgg(figure)
    heat_axes, mean_axes = figure.subplots(2, 1, height_ratios=(2.0, 1.0), sharex=True)
    image = heat_axes.imshow(
        np.ma.masked_invalid(cosines),
        aspect="auto",
        cmap="RdBu_r",
        vmin=-1.0,
        vmax=1.0,
        interpolation="nearest",
        extent=(-0.5, cosines.shape[1] - 0.5, len(cosines) - 0.5, -0.5),
    )
    heat_axes.set_facecolor("0.85")
    heat_axes.set_ylabel("demonstration")
    heat_axes.set_title("cos(grad_q (f o phi)(q_t), q_{t+1} - q_t) (grey: no gradient or no step)")
    figure.colorbar(image, ax=heat_axes, label="cosine")
    steps = np.arange(cosines.shape[1])
    mean_axes.plot(steps, mean_over_demos(cosines), marker=".", label="all steps")
    mean_axes.plot(steps, mean_over_demos(moving), marker=".", label="steps that move")
    mean_axes.axhline(-1.0, color="grey", linestyle="--", linewidth=1)
    mean_axes.set_ylim(-1.05, 1.05)
    mean_axes.set_xlabel("step t")
    mean_axes.set_ylabel("mean over demos")
    mean_axes.grid(alpha=0.3)
    mean_axes.legend()
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=120)
    return path
