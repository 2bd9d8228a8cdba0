"""tric-analyze: the paper's analyses of a trained TRIC model, as PNGs (Fig. 13, 14a, 16 and 17a).

    tric-analyze MODEL BAGS... [--out DIR] [--top N]

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
Prints the share of demonstration steps along which f decreases, the mean cosine and the top
features. Exit status 0, or 2 with one line on stderr when the model or a bag is refused.
"""

import argparse
import pathlib
import sys

import matplotlib
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from tric_learning.dataset import Dataset
from tric_learning.model_file import ModelFile, value_function
from tric_learning.recording import load_dataset
from tric_learning.training import MIN_STEP, SELECTED_FRACTION
from tric_learning.value_function import ValueFunction
from tric_sim.output_files import atomic_path, check_output_folder
from tric_sim.robot_model import RobotModel

PROG = "tric-analyze"
VALUE_FIGURE = "value_along_demos.png"
COSINES_FIGURE = "gradient_cosines.png"
SCORES_FIGURE = "feature_scores.png"
GRADIENTS_FIGURE = "mean_gradients.png"
#: Features of Fig. 17a also drawn as lines.
GRADIENT_LINES = 6


def values_along_demos(model: ValueFunction, dataset: Dataset) -> list:
    """f(y_t) of each demo, [(T,)] in dataset order."""
    return [model.value(demo.y) for demo in dataset.demos]


def decreasing_shares(model: ValueFunction, dataset: Dataset):
    """(share of all steps t -> t+1 along which f decreases, the same over the steps where the
    demonstration moves by at least training.MIN_STEP rad)."""
    decreasing, moving = [], []
    for demo, values in zip(dataset.demos, values_along_demos(model, dataset)):
        decreasing.append(np.diff(values) < 0)
        moving.append(np.linalg.norm(np.diff(demo.q, axis=0), axis=1) >= MIN_STEP)
    decreasing, moving = np.concatenate(decreasing), np.concatenate(moving)
    return float(decreasing.mean()), float(decreasing[moving].mean()) if moving.any() else float("nan")


def cosines_along_demos(model: ValueFunction, dataset: Dataset, min_step: float = 0.0) -> np.ndarray:
    """L_g's cosine (Eq. 17) between grad_q (f o phi)(q_t) = (df/dy)(y_t) dphi/dq(q_t) and the step
    q_{t+1} - q_t, (N, T_max - 1) for N demos of at most T_max samples: NaN past a demo's end, where
    the step is shorter than min_step rad or is zero, and where the gradient is zero."""
    longest = max(demo.length for demo in dataset.demos)
    cosines = np.full((len(dataset.demos), longest - 1), np.nan)
    for i, demo in enumerate(dataset.demos):
        steps = np.diff(demo.q, axis=0)
        gradients = np.array([model.gradient(y)[1] @ jacobian for y, jacobian in zip(demo.y[:-1], demo.jacobians)])
        step_norms = np.linalg.norm(steps, axis=1)
        norms = step_norms * np.linalg.norm(gradients, axis=1)
        defined = np.flatnonzero((step_norms >= min_step) & (norms > 0))
        cosines[i, defined] = np.einsum("tn,tn->t", gradients[defined], steps[defined]) / norms[defined]
    return cosines


def moving_only(cosines: np.ndarray, dataset: Dataset) -> np.ndarray:
    """cosines (N, T_max - 1) from cosines_along_demos() with NaN where the step is shorter than
    MIN_STEP rad: the same as cosines_along_demos(..., MIN_STEP), without computing them again."""
    lengths = np.full(cosines.shape, np.nan)
    for i, demo in enumerate(dataset.demos):
        lengths[i, :demo.length - 1] = np.linalg.norm(np.diff(demo.q, axis=0), axis=1)
    return np.where(lengths >= MIN_STEP, cosines, np.nan)


def gradients_along_demos(model: ValueFunction, dataset: Dataset) -> np.ndarray:
    """df/du at every sample, u the kept features rescaled to [0, 1] (the paper's y):
    (N, T_max, s) for N demos of at most T_max samples, NaN past a demo's end."""
    longest = max(demo.length for demo in dataset.demos)
    gradients = np.full((len(dataset.demos), longest, len(model.scaling.kept)), np.nan)
    for i, demo in enumerate(dataset.demos):
        for t, u in enumerate(model.scaling.transform(demo.y)):
            gradients[i, t] = model.scaled_gradient(u)[1]
    return gradients


def mean_over_demos(values: np.ndarray) -> np.ndarray:
    """The mean over the first axis (demos) of the finite entries of values (N, ...), (...); NaN
    where no demo has one (e.g. past every demo's end)."""
    counts = np.sum(np.isfinite(values), axis=0)
    sums = np.nansum(values, axis=0)
    return np.divide(sums, counts, out=np.full(sums.shape, np.nan), where=counts > 0)


def score_order(model: ValueFunction) -> np.ndarray:
    """Indices into the kept features, highest score s(y) first, (s,)."""
    return np.argsort(-model.scores(), kind="stable")


def ranked_features(model: ValueFunction, feature_names) -> list:
    """[(name, score)] of the kept features, highest score s(y) first."""
    scores = model.scores()
    names = np.asarray(feature_names)[model.scaling.kept]
    return [(str(names[k]), float(scores[k])) for k in score_order(model)]


def plot_values(curves: list, names: list, path: pathlib.Path) -> pathlib.Path:
    """Fig. 13: each demo's f over normalized time, coloured by demo index."""
    figure = Figure(figsize=(7.0, 4.5), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    colours = matplotlib.colormaps["viridis"].resampled(max(len(curves), 2))
    for k, values in enumerate(curves):
        axes.plot(np.linspace(0.0, 1.0, len(values)), values, color=colours(k), linewidth=1.2, marker=".",
                  markersize=3)
    axes.set_xlabel("normalized time t / (T - 1)")
    axes.set_ylabel("value f(y_t)")
    axes.set_title(f"f along {len(curves)} demonstrations ({names[0]} ... {names[-1]})" if len(names) > 1
                   else f"f along {names[0]}")
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
    image = heat_axes.imshow(np.ma.masked_invalid(cosines), aspect="auto", cmap="RdBu_r", vmin=-1.0, vmax=1.0,
                             interpolation="nearest", extent=(-0.5, cosines.shape[1] - 0.5, len(cosines) - 0.5, -0.5))
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


def plot_gradients(mean_gradient: np.ndarray, model: ValueFunction, feature_names, path: pathlib.Path,
                   top: int) -> pathlib.Path:
    """Fig. 17a: the mean gradient df/du (T, s) of the top features by score over the steps, as a
    heatmap (red: f grows with the feature, so the controller lowers it), and the top GRADIENT_LINES
    of them as lines."""
    chosen = score_order(model)[:top]
    names = [f"{rank + 1}. {name}" for rank, name in enumerate(np.asarray(feature_names)[model.scaling.kept][chosen])]
    shown = mean_gradient[:, chosen]
    bound = float(np.nanmax(np.abs(shown)))
    figure = Figure(figsize=(9.0, 5.0 + 0.25 * len(chosen)), layout="constrained")
    FigureCanvasAgg(figure)
    heat_axes, line_axes = figure.subplots(2, 1, height_ratios=(0.25 * len(chosen) + 1.0, 3.0), sharex=True)
    image = heat_axes.imshow(shown.T, aspect="auto", cmap="RdBu_r", vmin=-bound, vmax=bound, interpolation="nearest")
    heat_axes.set_yticks(np.arange(len(chosen)), names, fontsize=8)
    heat_axes.set_title(f"mean df/dy over the demonstrations, top {len(chosen)} features by score "
                        "(y rescaled to [0, 1])")
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
    """Fig. 16: all kept features' scores sorted (with the selection threshold) and the top ones named."""
    scores = np.array([score for _, score in ranked])
    threshold = SELECTED_FRACTION * scores.max()
    selected = int(np.sum(scores > threshold))
    figure = Figure(figsize=(11.0, 4.5 + 0.12 * min(top, len(ranked))), layout="constrained")
    FigureCanvasAgg(figure)
    sorted_axes, top_axes = figure.subplots(1, 2, width_ratios=(1.2, 1.0))
    sorted_axes.bar(np.arange(1, len(scores) + 1), scores, width=1.0, color="tab:blue")
    sorted_axes.axhline(threshold, color="tab:red", linestyle="--", linewidth=1,
                        label=f"{SELECTED_FRACTION:.0%} of the largest: {selected} selected")
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


def write_figures(model: ValueFunction, dataset: Dataset, out: pathlib.Path, top: int) -> list:
    """Fig. 13, 14a, 16 and 17a of model on dataset as out/VALUE_FIGURE, ... (out is created); their paths."""
    out.mkdir(parents=True, exist_ok=True)
    names = dataset.definition.feature_names
    cosines = cosines_along_demos(model, dataset)
    return [plot_values(values_along_demos(model, dataset), [demo.name for demo in dataset.demos], out / VALUE_FIGURE),
            plot_cosines(cosines, moving_only(cosines, dataset), out / COSINES_FIGURE),
            plot_scores(ranked_features(model, names), out / SCORES_FIGURE, top),
            plot_gradients(mean_over_demos(gradients_along_demos(model, dataset)), model, names,
                           out / GRADIENTS_FIGURE, top)]


def key_numbers(model: ValueFunction, dataset: Dataset, top: int) -> dict:
    """The analyses' numbers, JSON-ready: the steps t -> t + 1 of all demos and those that move by
    >= MIN_STEP rad; the shares of them along which f decreases; the demos that end lower than they
    start; the mean cosines of Fig. 14a (over the moving steps, over all steps, and over the moving
    steps before and from step late_from_step, 3/4 of the way); the kept and the selected features
    (score above SELECTED_FRACTION of the largest); the top features [{name, score}]; and how many of
    them have a mean gradient (Fig. 17a) that changes sign over time."""
    all_steps, moving_steps = decreasing_shares(model, dataset)
    cosines = cosines_along_demos(model, dataset)
    moving = moving_only(cosines, dataset)
    late = int(round(0.75 * moving.shape[1]))
    ranked = ranked_features(model, dataset.definition.feature_names)
    scores = np.array([score for _, score in ranked])
    mean_gradient = mean_over_demos(gradients_along_demos(model, dataset))[:, score_order(model)[:top]]

    def finite_mean(values):
        return float(np.mean(values[np.isfinite(values)])) if np.isfinite(values).any() else float("nan")

    return {
        "demos": len(dataset.demos),
        "steps": sum(demo.length - 1 for demo in dataset.demos),
        "moving_steps": int(sum(np.sum(np.linalg.norm(np.diff(demo.q, axis=0), axis=1) >= MIN_STEP)
                                for demo in dataset.demos)),
        "decreasing_share_all_steps": all_steps,
        "decreasing_share_moving_steps": moving_steps,
        "demos_ending_lower": int(sum(values[-1] < values[0] for values in values_along_demos(model, dataset))),
        "mean_cosine_moving_steps": finite_mean(moving),
        "mean_cosine_all_steps": finite_mean(cosines),
        "late_from_step": late,
        "mean_cosine_moving_early": finite_mean(moving[:, :late]),
        "mean_cosine_moving_late": finite_mean(moving[:, late:]),
        "kept_features": len(scores),
        "selected_features": int(np.sum(scores > SELECTED_FRACTION * scores.max())),
        "top_features": [{"name": name, "score": score} for name, score in ranked[:top]],
        "top_gradients_changing_sign": int(np.sum((np.nanmin(mean_gradient, axis=0) < 0)
                                                  & (np.nanmax(mean_gradient, axis=0) > 0))),
    }


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    parser.add_argument("model", metavar="MODEL", help="a TRIC model file (.safetensors)")
    parser.add_argument("bags", nargs="+", metavar="BAGS", help="MCAP bags, or folders of them")
    parser.add_argument("--out", default="analysis", metavar="DIR", help="folder for the PNGs (default: analysis)")
    parser.add_argument("--top", type=int, default=20,
                        help="features named in Fig. 16 and shown in Fig. 17a (default %(default)s)")
    args = parser.parse_args(argv)
    try:
        if args.top < 1:
            raise ValueError("--top must be at least 1")
        check_output_folder(args.out, "--out folder")
        dataset = load_dataset(args.bags, RobotModel())
        model = value_function(ModelFile.load(args.model, expected=dataset.definition))
        paths = write_figures(model, dataset, pathlib.Path(args.out), args.top)
    except (ValueError, OSError) as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    numbers = key_numbers(model, dataset, args.top)
    print(f"f decreases on {numbers['decreasing_share_all_steps']:.1%} of the steps of {numbers['demos']} "
          f"demonstrations ({numbers['decreasing_share_moving_steps']:.1%} of the steps that move by >= "
          f"{MIN_STEP} rad)")
    print(f"mean cosine of grad_q (f o phi) and the step: {numbers['mean_cosine_moving_steps']:.3f} over the steps "
          f"that move ({numbers['mean_cosine_all_steps']:.3f} over all)")
    print(f"selected features: {numbers['selected_features']} of {numbers['kept_features']} kept")
    print("top features: " + ", ".join(f"{t['name']} {t['score']:.3g}" for t in numbers["top_features"][:5]))
    print(f"wrote {', '.join(str(path) for path in paths)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
