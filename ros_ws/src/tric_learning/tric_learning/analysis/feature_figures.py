"""Which features the value function uses: Fig. 16 (the kept features' scores), Fig. 17a (the mean
gradient df/dy of the top features over the steps) and Fig. 17b/c (one feature's raw value and
gradient along the demonstrations)."""

import pathlib

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from tric_learning.analysis.drawing import light_and_mean
from tric_learning.analysis.measures import score_order
from tric_learning.training.value import SELECTED_FRACTION
from tric_learning.value_function import ValueFunction
from tric_sim.tools.output_files import atomic_path

#: Features of Fig. 17a also drawn as lines.
GRADIENT_LINES = 6


def plot_gradients(
    mean_gradient: np.ndarray, model: ValueFunction, feature_names, path: pathlib.Path, top: int
) -> pathlib.Path:
    """Fig. 17a: the mean gradient df/du (T, s) of the top features by score over the steps, as a
    heatmap (red: f grows with the feature, so the controller lowers it), and the top GRADIENT_LINES
    of them as lines."""
    chosen = score_order(model)[:top]
    names = [
        f"{rank + 1}. {name}"
        for rank, name in enumerate(np.asarray(feature_names)[model.scaling.kept][chosen])
    ]
    shown = mean_gradient[:, chosen]
    bound = float(np.nanmax(np.abs(shown)))
    figure = Figure(figsize=(9.0, 5.0 + 0.25 * len(chosen)), layout="constrained")
    FigureCanvasAgg(figure)
    heat_axes, line_axes = figure.subplots(
        2, 1, height_ratios=(0.25 * len(chosen) + 1.0, 3.0), sharex=True
    )
    image = heat_axes.imshow(
        shown.T, aspect="auto", cmap="RdBu_r", vmin=-bound, vmax=bound, interpolation="nearest"
    )
    heat_axes.set_yticks(np.arange(len(chosen)), names, fontsize=8)
    heat_axes.set_title(
        f"mean df/dy over the demonstrations, top {len(chosen)} features by score "
        "(y rescaled to [0, 1])"
    )
    figure.colorbar(image, ax=heat_axes, label="df/dy")
    for k in range(min(GRADIENT_LINES, len(chosen))):
        line_axes.plot(shown[:, k], marker=".", label=names[k])
    line_axes.axhline(0.0, color="grey", linewidth=1)
    line_axes.set_xlabel("step t")
    line_axes.set_ylabel("df/dy")
    line_axes.grid(alpha=0.3)
    line_axes.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=120)
    return path


def plot_scores(ranked: list, path: pathlib.Path, top: int) -> pathlib.Path:
    """Fig. 16: all kept features' scores sorted (with the selection threshold) and the top ones
    named."""
    scores = np.array([score for _, score in ranked])
    threshold = SELECTED_FRACTION * scores.max()
    selected = int(np.sum(scores > threshold))
    figure = Figure(figsize=(11.0, 4.5 + 0.12 * min(top, len(ranked))), layout="constrained")
    FigureCanvasAgg(figure)
    sorted_axes, top_axes = figure.subplots(1, 2, width_ratios=(1.2, 1.0))
    sorted_axes.bar(np.arange(1, len(scores) + 1), scores, width=1.0, color="tab:blue")
    sorted_axes.axhline(
        threshold,
        color="tab:red",
        linestyle="--",
        linewidth=1,
        label=f"{SELECTED_FRACTION:.0%} of the largest: {selected} selected",
    )
    sorted_axes.set_xlabel("feature rank")
    sorted_axes.set_ylabel("score s(y)")
    sorted_axes.set_title(f"{len(scores)} kept features by score")
    sorted_axes.legend()
    shown = ranked[:top]
    top_axes.barh(np.arange(len(shown)), [score for _, score in shown], color="tab:blue")
    top_axes.set_yticks(np.arange(len(shown)), [name for name, _ in shown], fontsize=8)
    top_axes.invert_yaxis()
    top_axes.set_xlabel("score s(y)")
    top_axes.set_title(f"top {len(shown)}")
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=120)
    return path


def plot_feature_over_time(
    values: np.ndarray, gradients: np.ndarray, name: str, rank: int, path: pathlib.Path
) -> pathlib.Path:
    """Fig. 17b/c: the raw value (N, T) and df/du (N, T) of one feature by step, each demo light and
    their mean over the demos bold."""
    figure = Figure(figsize=(8.0, 6.5), layout="constrained")
    FigureCanvasAgg(figure)
    value_axes, gradient_axes = figure.subplots(2, 1, sharex=True)
    light_and_mean(
        value_axes, values, "tab:blue", f"mean over {len(values)} demonstrations (light: each)"
    )
    value_axes.set_ylabel("raw value (m)")
    value_axes.set_title(f"(b) the raw value of the feature ranked {rank}: {name}")
    value_axes.grid(alpha=0.3)
    value_axes.legend()
    light_and_mean(gradient_axes, gradients, "tab:red", "mean")
    gradient_axes.axhline(0.0, color="grey", linewidth=1)
    gradient_axes.set_xlabel("step t")
    gradient_axes.set_ylabel("df/du (u: the feature rescaled to [0, 1])")
    gradient_axes.set_title(
        "(c) the gradient of f along it (> 0: the controller lowers the feature)"
    )
    gradient_axes.grid(alpha=0.3)
    gradient_axes.legend()
    figure.suptitle("one feature along the demonstrations (paper Fig. 17b/c)")
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=120)
    return path
