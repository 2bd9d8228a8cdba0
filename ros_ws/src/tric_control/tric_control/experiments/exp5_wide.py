"""Experiment 5, second half (ours): the models of Tables 1, 3 and 4, trained as they are, on
situations wider than their training sets: boxes turned within +-45 degrees with their centre ranges
widened by half on each side (box_wide), spheres up to 10 cm outside the training grid
(sphere_wide), cylinders turned up to 45 degrees beyond [0, pi/2] (cylinder_wide). Success against
the distance from the training range (tric_sim.world.situations.outside_training_range)."""

from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tric_control.evaluation.records import report  # noqa: E402
from tric_control.experiments.rows import spread  # noqa: E402
from tric_control.experiments.runner import Runner  # noqa: E402
from tric_sim.world import situations  # noqa: E402

#: The experiment's heading in the report and the log.
TITLE = (
    "Wider situations than the training sets': boxes turned within +-45 degrees on widened "
    "ranges, spheres up to 10 cm outside the grid, cylinders turned beyond [0, pi/2]; TRIC and "
    "DPL (three groups each) and the teacher."
)

#: Each wide set's agents (Runner.model's arguments; None: the teacher).
SETS: dict[str, dict[str, dict[str, Any] | None]] = {
    "box_wide": {
        "teacher": None,
        "TRIC": dict(name="box_k30", bags="box"),
        "DPL joint space": dict(name="box_dpl_joint", bags="box", kind="dpl_joint"),
        "DPL finger space": dict(name="box_dpl_finger", bags="box", kind="dpl_finger"),
    },
    "sphere_wide": {
        "teacher": None,
        "TRIC": dict(name="sphere_k30", bags="sphere"),
        "DPL joint space": dict(name="sphere_dpl_joint", bags="sphere", kind="dpl_joint"),
    },
    "cylinder_wide": {
        "teacher": None,
        "TRIC": dict(name="cylinder_k30", bags="cylinder"),
        "DPL joint space": dict(name="cylinder_dpl_joint", bags="cylinder", kind="dpl_joint"),
    },
}
#: Bins of the distance from the training range (a share of its width): (low, high], and 0 alone.
BINS = ((-1.0, 0.0), (0.0, 0.15), (0.15, 0.3), (0.3, 1.0))


def run(runner: Runner) -> dict:
    """The experiment's rows, table, figure, the paper's numbers (none) and the discussion."""
    rows: dict[str, dict] = {}
    for name, agents in SETS.items():
        chosen = runner.situations(name)
        distances = [situations.outside_training_range(s, runner.profile.workspace) for s in chosen]
        rows[name] = {"distances": distances, "agents": {}}
        for label, model in agents.items():
            by_seed = (
                {"-": runner.evaluate(chosen, None, f"teacher, {name}")}
                if model is None
                else runner.over_seeds(chosen, f"{label}, {name}", **model)
            )
            rows[name]["agents"][label] = {
                str(seed): {
                    "ok": sum(r.success for r in records),
                    "episodes": len(records),
                    "by_bin": _by_bin(records, distances),
                    "collisions": sum(r.collided for r in records),
                    "records": report(records)["episodes"],
                }
                for seed, records in by_seed.items()
            }
    return {
        "rows": rows,
        "table": table(rows),
        "figure": _figure(rows),
        "paper": "no number: the paper's test boxes are 'quite different situations', where DPL "
        "in joint space opens 2 of 25 and TRIC 24",
        "discussion": discussion(rows),
    }


def _by_bin(records, distances) -> list:
    """[successes, episodes] in each of BINS."""
    return [
        [
            sum(r.success for r, d in zip(records, distances) if low < d <= high),
            sum(low < d <= high for d in distances),
        ]
        for low, high in BINS
    ]


def _bin_label(low: float, high: float) -> str:
    return "0" if low < 0 else f"{low:g}-{high:g}"


def table(rows: dict) -> str:
    lines = [
        f"{'set':14s} {'agent':17s} {'seed':>4s} {'success':>9s}  by distance from the training "
        "range (share of its width): " + ", ".join(_bin_label(*b) for b in BINS)
    ]
    for name, row in rows.items():
        for label, seeds in row["agents"].items():
            for seed, cell in seeds.items():
                lines.append(
                    f"{name:14s} {label:17s} {seed:>4s} {cell['ok']:4d}/{cell['episodes']:<4d} "
                    + "  ".join(f"{ok}/{n}" for ok, n in cell["by_bin"])
                    + (f"  ({cell['collisions']} collisions)" if cell["collisions"] else "")
                )
    return "\n".join(lines)


def discussion(rows: dict) -> str:
    parts = []
    for name, row in rows.items():
        agents = row["agents"]
        n = len(row["distances"])
        text = f"On {name} ({n} situations) " + ", ".join(
            f"{label} succeeds in {spread([cell['ok'] for cell in seeds.values()])}"
            for label, seeds in agents.items()
        )
        tric = [cell["ok"] for cell in agents["TRIC"].values()]
        dpl = [
            cell["ok"]
            for label, seeds in agents.items()
            if "DPL" in label
            for cell in seeds.values()
        ]
        text += (
            ": TRIC holds up better than DPL with every group."
            if min(tric) > max(dpl)
            else f": TRIC does not hold up better than DPL with every group (TRIC at worst "
            f"{min(tric)}, DPL at best {max(dpl)})."
        )
        parts.append(text)
    return " ".join(parts)


def _figure(rows: dict):
    figure, axes = plt.subplots(1, len(rows), figsize=(3.6 * len(rows), 3.2), sharey=True)
    labels = [_bin_label(*b) for b in BINS]
    for axis, (name, row) in zip(axes, rows.items()):
        for label, seeds in row["agents"].items():
            # a bin without situations has no share (NaN: not drawn); every group sees the same
            # situations, so a bin's column is NaN for all of them or for none
            shares = np.array(
                [[ok / n if n else np.nan for ok, n in cell["by_bin"]] for cell in seeds.values()]
            )
            line = axis.plot(labels, shares.mean(axis=0), marker="o", label=label)[0]
            if len(seeds) > 1:
                axis.fill_between(
                    labels,
                    shares.min(axis=0),
                    shares.max(axis=0),
                    color=line.get_color(),
                    alpha=0.2,
                )
        axis.set_title(name)
        axis.set_xlabel("distance from the training range\n(share of its width)")
    axes[0].set_ylabel("success rate (band: range over seeds)")
    # one legend for every agent of every set (DPL in finger space runs on the boxes only)
    legend: dict = {}
    for axis in axes:
        handles, labels = axis.get_legend_handles_labels()
        legend.update(zip(labels, handles))
    axes[-1].legend(legend.values(), legend.keys(), fontsize=7)
    return figure
