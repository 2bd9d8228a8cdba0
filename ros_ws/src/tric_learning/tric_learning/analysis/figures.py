"""The paper's analyses of a trained TRIC model, as PNGs (Fig. 12, 13, 14a, 14b, 15, 16 and 17a-c),
and their key numbers (tric-analyze, tric-experiments' analysis). In the folder DIR:

Fig. 13 (DIR/value_along_demos.png): the value f(y_t) along every demonstration in BAGS (bags or
folders of bags, the training ones or others of the same feature definition) over normalized time
t / (T - 1); a model that explains its demonstrations decreases along each of them.
Fig. 14a (DIR/gradient_cosines.png): L_g's cosine between grad_q (f o phi)(q_t) = (df/dy)(dphi/dq),
from the recorded Jacobians, and the demonstrated step q_{t+1} - q_t, for every demonstration and
step (a heatmap; -1: f falls fastest along the step), and its mean over the demonstrations by step.
Fig. 16 (DIR/feature_scores.png): the kept features' scores s(y) = |W1^T| |W2| + |W3| (Sec. 5.5.1),
sorted, with the selection threshold, and the top N (20) by name.
Fig. 17a (DIR/mean_gradients.png): the mean over the demonstrations of df/dy at each step (on the
features rescaled to [0, 1], the paper's y) for the top N features by score.
Fig. 12 (DIR/box_task_spaces.png, box bags only): the first FIG12_DEMOS box openings in three task
spaces, in 3D, start green, end red: the joints' first three principal components (over those
demonstrations' samples), the box in fingertip 2's frame (the recorded p[fingertip_2->box]) and
fingertip 2 in the box's frame (p[box->fingertip_2]).
Fig. 14b (DIR/collision_prior.png): the controller's collision prior along the demonstrations: per
step, the smallest signed distance (m) between the hand (palm and finger links) and the body it may
touch (the grasp target, or the box's lid), and how many such hand-body pairs are within the
controller's influence distance CONTROLLER_INFLUENCE; each demonstration light, their mean bold.
Distances from the recorded q and object poses with coal on the robot's collision model.
Fig. 15 (DIR/kernel_pca.png): kernel PCA (Gaussian kernel, bandwidth by the median heuristic: the
median distance between the samples) of every demonstration sample's kept features rescaled to
[0, 1], and of the hidden layer z = sigmoid(W1 u) (Sec. 5.4.2), in 2-D, coloured by f, the last
samples ringed; a linear model (K = 0) has no z, and only the first panel is drawn.
Fig. 17b/c (DIR/feature_over_time.png): the raw value (m) and df/du of the feature ranked
--feature-rank (8, as the paper's) by score, over the steps: each demonstration light, the mean
bold.
"""

import pathlib

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from tric_learning.analysis.measures import (
    CONTROLLER_INFLUENCE,
    DEFAULT_FEATURE_RANK,
    FIG12_DEMOS,
    FIG12_FINGER,
    FIG12_OBJECT,
    cosines_along_demos,
    feature_over_time,
    feature_paths,
    gradients_along_demos,
    hand_body_distances,
    hand_geometries,
    joint_principal_paths,
    kernel_pca,
    kernel_pca_inputs,
    mean_over_demos,
    moving_only,
    ranked_features,
    relative_spread,
    score_order,
    values_along_demos,
)
from tric_learning.dataset import Dataset
from tric_learning.training import SELECTED_FRACTION
from tric_learning.value_function import ValueFunction
from tric_sim.output_files import atomic_path
from tric_sim.robot_model import RobotModel

VALUE_FIGURE = "value_along_demos.png"


COSINES_FIGURE = "gradient_cosines.png"


SCORES_FIGURE = "feature_scores.png"


GRADIENTS_FIGURE = "mean_gradients.png"


TASK_SPACES_FIGURE = "box_task_spaces.png"


COLLISION_FIGURE = "collision_prior.png"


KERNEL_PCA_FIGURE = "kernel_pca.png"


FEATURE_FIGURE = "feature_over_time.png"


#: Features of Fig. 17a also drawn as lines.
GRADIENT_LINES = 6


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
    figure.savefig(path, dpi=120)
    return path


def _light_and_mean(axes, values: np.ndarray, colour: str, label: str):
    """Each row of values (N, T) as a light line and their mean over the rows as a bold one."""
    steps = np.arange(values.shape[1])
    for row in values:
        axes.plot(steps, row, color=colour, alpha=0.2, linewidth=0.8)
    axes.plot(steps, mean_over_demos(values), color=colour, linewidth=2.2, label=label)


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
    _light_and_mean(
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
    _light_and_mean(count_axes, counts, "tab:purple", "mean")
    count_axes.set_ylim(-0.3, geometries + 0.3)
    count_axes.set_xlabel("step t")
    count_axes.set_ylabel(f"hand-{role} pairs within {influence * 100:.0f} cm\n(of {geometries})")
    count_axes.grid(alpha=0.3)
    count_axes.legend()
    figure.suptitle("the controller's collision prior along the demonstrations (paper Fig. 14b)")
    figure.savefig(path, dpi=120)
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
        axes.scatter(*projected.T, c=inputs["value"], cmap="viridis", norm=norm, s=9)
        axes.scatter(
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
    figure.savefig(path, dpi=120)
    return path


def plot_feature_over_time(
    values: np.ndarray, gradients: np.ndarray, name: str, rank: int, path: pathlib.Path
) -> pathlib.Path:
    """Fig. 17b/c: the raw value (N, T) and df/du (N, T) of one feature by step, each demo light and
    their mean over the demos bold."""
    figure = Figure(figsize=(8.0, 6.5), layout="constrained")
    FigureCanvasAgg(figure)
    value_axes, gradient_axes = figure.subplots(2, 1, sharex=True)
    _light_and_mean(
        value_axes, values, "tab:blue", f"mean over {len(values)} demonstrations (light: each)"
    )
    value_axes.set_ylabel("raw value (m)")
    value_axes.set_title(f"(b) the raw value of the feature ranked {rank}: {name}")
    value_axes.grid(alpha=0.3)
    value_axes.legend()
    _light_and_mean(gradient_axes, gradients, "tab:red", "mean")
    gradient_axes.axhline(0.0, color="grey", linewidth=1)
    gradient_axes.set_xlabel("step t")
    gradient_axes.set_ylabel("df/du (u: the feature rescaled to [0, 1])")
    gradient_axes.set_title(
        "(c) the gradient of f along it (> 0: the controller lowers the feature)"
    )
    gradient_axes.grid(alpha=0.3)
    gradient_axes.legend()
    figure.suptitle("one feature along the demonstrations (paper Fig. 17b/c)")
    figure.savefig(path, dpi=120)
    return path


def write_figures(
    model: ValueFunction,
    dataset: Dataset,
    out: pathlib.Path,
    top: int,
    feature_rank: int = DEFAULT_FEATURE_RANK,
    robot: RobotModel = None,
) -> list:
    """The figures of model on dataset in out (created): Fig. 13, 14a, 16, 17a, 15 and 17b/c, then
    Fig. 12 for box-opening demos and Fig. 14b when a robot model is given; their paths."""
    out.mkdir(parents=True, exist_ok=True)
    names = dataset.definition.feature_names
    cosines = cosines_along_demos(model, dataset)
    gradients = gradients_along_demos(model, dataset)
    paths = [
        plot_values(
            values_along_demos(model, dataset),
            [demo.name for demo in dataset.demos],
            out / VALUE_FIGURE,
        ),
        plot_cosines(cosines, moving_only(cosines, dataset), out / COSINES_FIGURE),
        plot_scores(ranked_features(model, names), out / SCORES_FIGURE, top),
        plot_gradients(mean_over_demos(gradients), model, names, out / GRADIENTS_FIGURE, top),
        plot_kernel_pca(kernel_pca_inputs(model, dataset), out / KERNEL_PCA_FIGURE),
        plot_feature_over_time(
            *feature_over_time(model, dataset, feature_rank, gradients),
            feature_rank,
            out / FEATURE_FIGURE,
        ),
    ]
    if dataset.definition.task == "open_box":
        paths.append(plot_task_spaces(dataset, out / TASK_SPACES_FIGURE))
    if robot is not None:
        distances, counts, role = hand_body_distances(robot, dataset)
        paths.append(
            plot_collision_prior(
                distances, counts, role, len(hand_geometries(robot)), out / COLLISION_FIGURE
            )
        )
    return paths
