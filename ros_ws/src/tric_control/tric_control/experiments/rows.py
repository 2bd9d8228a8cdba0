"""Grasp rows (an agent's numbers over its episodes, or over its seeds), their table and bar
chart, shared by the grasp experiments."""

import math

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tric_control.evaluation.records import report, summarize  # noqa: E402
from tric_sim.physics.metrics import GOOD_GRASP  # noqa: E402


def grasp_row(records) -> dict:
    s = summarize(records)
    costs = [r.grasp_cost for r in records if math.isfinite(r.grasp_cost)]
    return {
        "cost_mean": s["grasp_cost_mean"],
        "cost_std": float(np.std(costs)) if costs else math.nan,
        "cost_max": s["grasp_cost_max"],
        "good": s["good_grasps"],
        "lift": s["lift_passed"],
        "collisions": s["collisions"],
        "episodes": len(records),
        "at_rest": at_rest(s),
        "records": report(records)["episodes"],
    }


def at_rest(summary: dict):
    """Of a controller's episodes (evaluation.summarize's summary) that did their task, how many
    came to rest before the step budget; None for the teacher's, which run for a fixed time."""
    controlled = summary["converged"] + summary["step_budget"]
    return summary["done_converged"] if controlled else None


def rest_share(rows) -> float:
    """Of the episodes that did their task in rows (grasp or box rows, with "at_rest" and "good"
    or "opened"), the share that came to rest before the step budget (NaN if none did it)."""
    done = sum(row.get("good", row.get("opened", 0)) for row in rows)
    return sum(row["at_rest"] for row in rows) / done if done else math.nan


def rest_cell(row: dict) -> str:
    """'at rest/done' of a grasp or box row, '-' for the teacher's."""
    done = row.get("good", row.get("opened"))
    return "-" if row["at_rest"] is None else f"{row['at_rest']}/{done}"


def grasp_rows(runner, tests, models: dict) -> dict:
    """The teacher's grasp row on tests, then the seeded grasp row of each model ({label:
    Runner.model's arguments}) over the runner's seeds, in that order."""
    rows = {"teacher": grasp_row(runner.evaluate(tests, None, "teacher"))}
    for label, model in models.items():
        rows[label] = seeded_grasp_row(runner.over_seeds(tests, label, **model))
    return rows


def grasp_result(rows: dict, figure_title: str, paper: str, discussion: str) -> dict:
    """A grasp experiment's result: its rows, their table and cost bars, the paper's numbers and
    the discussion."""
    return {
        "rows": rows,
        "table": grasp_table(rows),
        "figure": cost_bars(figure_title, rows),
        "paper": paper,
        "discussion": discussion,
    }


def seeded_grasp_row(by_seed: dict) -> dict:
    """Grasp rows of each seed ({seed: [EpisodeRecord]}) and their spread: the mean, lowest and
    highest of the seeds' mean costs, and the good, lifted and collided counts by seed."""
    seeds = {seed: grasp_row(records) for seed, records in by_seed.items()}
    means = [row["cost_mean"] for row in seeds.values()]
    return {
        "seeds": seeds,
        "cost_mean": float(np.mean(means)),
        "cost_min": float(np.min(means)),
        "cost_max_seed": float(np.max(means)),
        "good": [row["good"] for row in seeds.values()],
        "lift": [row["lift"] for row in seeds.values()],
        "collisions": [row["collisions"] for row in seeds.values()],
        "at_rest": [row["at_rest"] for row in seeds.values()],
        "episodes": next(iter(seeds.values()))["episodes"],
    }


def spread(values, fmt: str = "d") -> str:
    """'a/b/c (mean m, min x, max y)' of per-seed values."""
    text = "/".join(format(v, fmt) for v in values)
    if len(values) < 2:
        return text
    mean_fmt = ".1f" if fmt == "d" else fmt
    return (
        f"{text} (mean {format(float(np.mean(values)), mean_fmt)}, min {format(min(values), fmt)}, "
        f"max {format(max(values), fmt)})"
    )


def grasp_table(rows: dict) -> str:
    """One line per agent, or per seed of a seeded agent followed by its spread over the seeds."""
    lines = [
        f"{'agent':18s} {'seed':>4s} {'cost mean':>10s} {'std':>6s} {'max':>6s} {'good':>6s} "
        f"{'lift':>5s} {'collisions':>10s} {'good at rest':>12s}"
    ]

    def line(name, seed, r):
        return (
            f"{name:18s} {seed:>4s} {r['cost_mean']:10.3f} {r['cost_std']:6.3f} "
            f"{r['cost_max']:6.3f} {r['good']:3d}/{r['episodes']:<2d} {r['lift']:5d} "
            f"{r['collisions']:10d} {rest_cell(r):>12s}"
        )

    for name, row in rows.items():
        if "seeds" not in row:
            lines.append(line(name, "-", row))
            continue
        lines += [line(name, str(seed), r) for seed, r in row["seeds"].items()]
        lines.append(
            f"{'':18s} {'all':>4s} mean cost "
            f"{spread([r['cost_mean'] for r in row['seeds'].values()], '.3f')}; good "
            f"{spread(row['good'])}; lift {spread(row['lift'])}"
        )
    return "\n".join(lines)


def cost_bars(title: str, rows: dict):
    """Mean grasp cost per agent; a seeded agent's bar is its seeds' mean, its error bar their
    range."""
    figure, axis = plt.subplots(figsize=(5.5, 3.2))
    names = list(rows)
    means = [rows[n]["cost_mean"] for n in names]
    low = [
        rows[n]["cost_mean"] - rows[n]["cost_min"] if "seeds" in rows[n] else rows[n]["cost_std"]
        for n in names
    ]
    high = [
        rows[n]["cost_max_seed"] - rows[n]["cost_mean"]
        if "seeds" in rows[n]
        else rows[n]["cost_std"]
        for n in names
    ]
    axis.bar(names, means, yerr=[low, high], capsize=3)
    axis.axhline(GOOD_GRASP, color="grey", linestyle="--", linewidth=1)
    axis.set_ylabel("grasp cost (bars: range over seeds)")
    axis.set_title(title)
    return figure


def mean_difference_is_clear(a: dict, b: dict) -> bool:
    """Whether the mean costs of two rows differ by more than twice the standard error of their
    difference."""
    error = math.sqrt(a["cost_std"] ** 2 / a["episodes"] + b["cost_std"] ** 2 / b["episodes"])
    return abs(a["cost_mean"] - b["cost_mean"]) > 2.0 * error
