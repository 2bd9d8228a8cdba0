"""How a model was chosen (its file's "selection" provenance, tric_control.selection): each
candidate's score against what the hidden metrics made of its rollouts from the demonstrations'
starts, the chosen ones marked. The metrics are a reference here: the default score never reads
them."""

import math
import pathlib

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from tric_sim.tools.output_files import atomic_path

#: The file name of the figure (tric-analyze, for a model file that records its selection).
SELECTION_FIGURE = "selection.png"


def rollout_outcome(rollouts: list) -> tuple:
    """(the rollouts' mean outcome, its axis label): the mean grasp cost of grasps (lower is
    better), the mean lid angle of boxes in rad."""
    angles = [r["lid_angle"] for r in rollouts if r.get("lid_angle") is not None]
    if angles:
        return sum(angles) / len(angles), "mean lid angle of its rollouts (rad)"
    costs = [1.0 if r.get("grasp_cost") is None else r["grasp_cost"] for r in rollouts]
    return sum(costs) / len(costs), "mean grasp cost of its rollouts (hidden metric)"


def _lift_untested(rows) -> bool:
    """Whether the rollouts' grasps were judged without the lift test (the selection leaves it out
    unless its score reads it)."""
    return any(
        r.get("grasp_cost") is not None and r.get("lift_passed") is None
        for row in rows
        for r in row["rollouts"]
    )


def plot_selection(provenance: dict, path: pathlib.Path) -> pathlib.Path:
    """Each candidate's score (x) against its rollouts' outcome (y), the successes beside each
    point, the chosen ones as stars; the failed ones (no score) at the right edge."""
    figure = Figure(figsize=(7.0, 4.5), layout="constrained")
    FigureCanvasAgg(figure)
    axes = figure.add_subplot()
    rows = provenance["candidates"]
    finite = [row["score"] for row in rows if row["score"] is not None]
    edge = max(finite) * 1.1 if finite else 1.0
    label = ""
    for row in rows:
        outcome, label = rollout_outcome(row["rollouts"])
        score = row["score"] if row["score"] is not None else edge
        successes = sum(bool(r["success"]) for r in row["rollouts"])
        axes.scatter(
            [score],
            [outcome],
            marker="*" if row["chosen"] else "o",
            s=180 if row["chosen"] else 40,
            color="tab:red" if row["chosen"] else "tab:blue",
            zorder=3,
        )
        axes.annotate(
            f"s{row['seed']} ({successes}/{len(row['rollouts'])})",
            (score, outcome),
            textcoords="offset points",
            xytext=(5, 4),
            fontsize=8,
        )
    config = provenance["config"]
    axes.set_xlabel(f"score '{config['score']}' (lower is better)")
    axes.set_ylabel(label)
    chosen = ", ".join(str(seed) for seed in provenance["chosen"])
    axes.set_title(
        f"{len(rows)} candidates from group {provenance['group_seed']}: kept seed {chosen} "
        f"(stars); successes of their rollouts in brackets"
        + (" (good grasps: no lift test)" if _lift_untested(rows) else "")
    )
    axes.grid(alpha=0.3)
    if finite and min(finite) > 0 and max(finite) / min(finite) > 30:
        axes.set_xscale("log")
    if not math.isfinite(edge):
        axes.set_xlim(right=1.0)
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=110)
    return path
