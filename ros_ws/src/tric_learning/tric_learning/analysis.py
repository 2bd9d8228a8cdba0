"""tric-analyze: the paper's analyses of a trained TRIC model, as PNGs (Fig. 13 and Fig. 16).

    tric-analyze MODEL BAGS... [--out DIR] [--top N]

Fig. 13 (DIR/value_along_demos.png): the value f(y_t) along every demonstration in BAGS (bags or
folders of bags, the training ones or others of the same feature definition) over normalized time
t / (T - 1); a model that explains its demonstrations decreases along each of them.
Fig. 16 (DIR/feature_scores.png): the kept features' scores s(y) = |W1^T| |W2| + |W3| (Sec. 5.5.1),
sorted, with the selection threshold, and the top N (20) by name.
Prints the share of demonstration steps along which f decreases and the top features. Exit status 0,
or 2 with one line on stderr when the model or a bag is refused.
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
from tric_sim.robot_model import RobotModel

PROG = "tric-analyze"
VALUE_FIGURE = "value_along_demos.png"
SCORES_FIGURE = "feature_scores.png"


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


def ranked_features(model: ValueFunction, feature_names) -> list:
    """[(name, score)] of the kept features, highest score s(y) first."""
    scores = model.scores()
    names = np.asarray(feature_names)[model.scaling.kept]
    order = np.argsort(-scores, kind="stable")
    return [(str(names[k]), float(scores[k])) for k in order]


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
    figure.savefig(path, dpi=120)
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
    figure.savefig(path, dpi=120)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    parser.add_argument("model", metavar="MODEL", help="a TRIC model file (.safetensors)")
    parser.add_argument("bags", nargs="+", metavar="BAGS", help="MCAP bags, or folders of them")
    parser.add_argument("--out", default="analysis", metavar="DIR", help="folder for the PNGs (default: analysis)")
    parser.add_argument("--top", type=int, default=20, help="features named in Fig. 16 (default %(default)s)")
    args = parser.parse_args(argv)
    try:
        if args.top < 1:
            raise ValueError("--top must be at least 1")
        dataset = load_dataset(args.bags, RobotModel())
        model = value_function(ModelFile.load(args.model, expected=dataset.definition))
        out = pathlib.Path(args.out)
        out.mkdir(parents=True, exist_ok=True)
        ranked = ranked_features(model, dataset.definition.feature_names)
        names = [demo.name for demo in dataset.demos]
        value_path = plot_values(values_along_demos(model, dataset), names, out / VALUE_FIGURE)
        scores_path = plot_scores(ranked, out / SCORES_FIGURE, args.top)
    except (ValueError, OSError) as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    all_steps, moving_steps = decreasing_shares(model, dataset)
    print(f"f decreases on {all_steps:.1%} of the steps of {len(dataset.demos)} demonstrations "
          f"({moving_steps:.1%} of the steps that move by >= {MIN_STEP} rad)")
    print("top features: " + ", ".join(f"{name} {score:.3g}" for name, score in ranked[:5]))
    print(f"wrote {value_path} and {scores_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
