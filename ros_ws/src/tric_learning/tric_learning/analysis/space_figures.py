"""The demonstrations in other spaces: Fig. 12 (box openings in joint space and in two task spaces,
in 3D) and Fig. 15 (kernel PCA of the scaled features and of the hidden layer, coloured by f)."""

import pathlib

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from tric_learning.analysis.measures import (
    FIG12_DEMOS,
    FIG12_FINGER,
    FIG12_OBJECT,
    feature_paths,
    joint_principal_paths,
    kernel_pca,
    relative_spread,
)
from tric_learning.training.dataset import Dataset
from tric_sim.tools.output_files import atomic_path


def _start_end(axes, path, colour, label):
    """One 3D path with its start (green) and end (red) marked."""
    axes.plot(*path.T, color=colour, linewidth=1.4, label=label)
    axes.scatter(*path[0], color="tab:green", s=30, depthshade=False)
    axes.scatter(*path[-1], color="tab:red", s=30, depthshade=False)


def plot_task_spaces(dataset: Dataset, path: pathlib.Path) -> pathlib.Path:
    """Fig. 12: the first FIG12_DEMOS box openings in joint space (3 principal components), the box
    in FIG12_FINGER's frame and FIG12_FINGER in the box's frame."""
    joints, share = joint_principal_paths(dataset)
    spaces = [
        (
            joints,
            f"(a) joint space: q on its first 3 principal components\n"
            f"({share.sum():.0%} of the variance)",
            [f"PC{k + 1} of q (rad)" for k in range(3)],
        ),
        (
            feature_paths(dataset, FIG12_FINGER, FIG12_OBJECT),
            f"(b) the box in {FIG12_FINGER}'s frame\np[{FIG12_FINGER}->{FIG12_OBJECT}]",
            [f"{axis} (m)" for axis in "xyz"],
        ),
        (
            feature_paths(dataset, FIG12_OBJECT, FIG12_FINGER),
            f"(c) {FIG12_FINGER} in the box's frame\np[{FIG12_OBJECT}->{FIG12_FINGER}]",
            [f"{axis} (m)" for axis in "xyz"],
        ),
    ]
    figure = Figure(figsize=(16.0, 5.8), layout="constrained")
    FigureCanvasAgg(figure)
    colours = matplotlib.colormaps["tab10"]
    names = [demo.name for demo in dataset.demos[:FIG12_DEMOS]]
    for column, (paths, title, labels) in enumerate(spaces):
        axes = figure.add_subplot(1, 3, column + 1, projection="3d")
        for k, (points, name) in enumerate(zip(paths, names)):
            _start_end(axes, points, colours(k), name)
        axes.set_title(title, fontsize=10)
        for setter, label in zip((axes.set_xlabel, axes.set_ylabel, axes.set_zlabel), labels):
            setter(label, fontsize=8)
        axes.tick_params(labelsize=7)
        axes.set_box_aspect(None, zoom=0.88)  # room for the z label
    handles, labels = figure.axes[0].get_legend_handles_labels()
    handles += [
        Line2D([], [], color="tab:green", marker="o", linestyle=""),
        Line2D([], [], color="tab:red", marker="o", linestyle=""),
    ]
    figure.legend(
        handles, labels + ["start", "end"], loc="outside lower center", ncol=len(labels) + 2
    )
    figure.suptitle(f"{len(names)} box openings in three task spaces (paper Fig. 12)")
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=120)
    return path


def plot_kernel_pca(inputs: dict, path: pathlib.Path) -> pathlib.Path:
    """Fig. 15: kernel PCA of the scaled features u and of the hidden layer z (when K > 0), coloured
    by f, each demo's last sample ringed."""
    panels = [("(a) features u (kept, rescaled to [0, 1])", inputs["u"])]
    if inputs["z"] is not None:
        panels.append(
            (f"(b) hidden layer z = sigmoid(W1 u), K = {inputs['z'].shape[1]}", inputs["z"])
        )
    figure = Figure(figsize=(6.0 * len(panels) + 1.5, 5.5), layout="constrained")
    FigureCanvasAgg(figure)
    norm = Normalize(float(np.min(inputs["value"])), float(np.max(inputs["value"])))
    last = inputs["last"]
    for column, (title, points) in enumerate(panels):
        axes = figure.add_subplot(1, len(panels), column + 1)
        projected, bandwidth = kernel_pca(points)
        # (the two columns of projected are x and y; mypy takes an unpacked array for every
        # positional parameter, s and c included)
        axes.scatter(*projected.T, c=inputs["value"], cmap="viridis", norm=norm, s=9)  # type: ignore[misc]
        axes.scatter(  # type: ignore[misc]
            *projected[last].T,
            facecolors="none",
            edgecolors="tab:red",
            s=45,
            linewidths=1.2,
            label="last sample of a demonstration",
        )
        axes.set_title(
            f"{title}\nGaussian kernel, median-heuristic bandwidth {bandwidth:.3g}; "
            f"last samples' spread {relative_spread(projected, last):.2f} of all",
            fontsize=9,
        )
        axes.set_xlabel("kernel principal component 1")
        axes.set_ylabel("kernel principal component 2")
        axes.grid(alpha=0.3)
        axes.legend(fontsize=8)
    if inputs["z"] is None:
        figure.axes[0].text(
            0.02,
            0.02,
            "K = 0: a linear model has no hidden layer z",
            transform=figure.axes[0].transAxes,
            fontsize=8,
        )
    figure.colorbar(ScalarMappable(cmap="viridis", norm=norm), ax=figure.axes, label="value f")
    figure.suptitle(f"kernel PCA of {len(last)} demonstration samples (paper Fig. 15)")
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=120)
    return path
