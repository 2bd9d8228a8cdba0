"""Table 4: boxes opened out of 25: TRIC, DPL in joint space, DPL in finger space, the teacher."""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tric_control.evaluation import report, summarize  # noqa: E402
from tric_control.experiments.paper import PAPER_BOXES, PAPER_REPORTS  # noqa: E402
from tric_control.experiments.rows import (  # noqa: E402
    at_rest,
    rest_cell,
    spread,
)
from tric_control.experiments.runner import Runner  # noqa: E402
from tric_control.experiments.targets import BOX_TARGET  # noqa: E402
from tric_sim import situations  # noqa: E402

#: The experiment's heading in the report and the log.
TITLE = (
    "Boxes opened out of the 25 test boxes: TRIC and both DPL variants with three training "
    "seeds each."
)


def run(runner: Runner) -> dict:
    """The experiment's rows, table, figure(s), the paper's numbers and the discussion."""
    tests = situations.dataset("box_test")
    agents = {
        "TRIC": dict(name="box_k30", bags="box"),
        "DPL joint space": dict(name="box_dpl_joint", bags="box", kind="dpl_joint"),
        "DPL finger space": dict(name="box_dpl_finger", bags="box", kind="dpl_finger"),
    }
    rows = {}
    for name, model in agents.items():
        by_seed = runner.over_seeds(tests, name, **model)
        seeds = {seed: _box_row(records) for seed, records in by_seed.items()}
        rows[name] = {
            "seeds": seeds,
            "opened": [r["opened"] for r in seeds.values()],
            "episodes": len(tests),
        }
    teacher = _box_row(runner.evaluate(tests, None, "teacher"))
    rows["teacher"] = {
        "seeds": {"-": teacher},
        "opened": [teacher["opened"]],
        "episodes": len(tests),
    }
    lines = [
        f"{'agent':18s} {'seed':>4s} {'opened':>8s} {'lid mean (rad)':>15s} {'collisions':>10s} "
        f"{'opened at rest':>14s}"
    ]
    for name, row in rows.items():
        lines += [
            f"{name:18s} {str(seed):>4s} {r['opened']:4d}/{r['episodes']:<3d} "
            f"{r['lid_mean']:15.2f} {r['collisions']:10d} {rest_cell(r):>14s}"
            for seed, r in row["seeds"].items()
        ]
        if len(row["seeds"]) > 1:
            lines.append(f"{'':18s} {'all':>4s} opened {spread(row['opened'])}")
    figure, axis = plt.subplots(figsize=(5.5, 3.2))
    means = [float(np.mean(r["opened"])) for r in rows.values()]
    axis.bar(
        list(rows),
        means,
        yerr=[
            [m - min(r["opened"]) for m, r in zip(means, rows.values())],
            [max(r["opened"]) - m for m, r in zip(means, rows.values())],
        ],
        capsize=3,
    )
    axis.set_ylabel(f"boxes opened of {len(tests)} (bars: range over seeds)")
    axis.set_title("Table 4: box opening")
    return {
        "rows": rows,
        "table": "\n".join(lines),
        "figure": figure,
        "paper": PAPER_REPORTS["table4"],
        "discussion": discussion(rows),
    }


def _box_row(records) -> dict:
    s = summarize(records)
    return {
        "opened": s["boxes_opened"],
        "episodes": len(records),
        "lid_mean": s["lid_angle_mean"],
        "collisions": s["collisions"],
        "at_rest": at_rest(s),
        "records": report(records)["episodes"],
    }


def discussion(rows: dict) -> str:
    n = rows["TRIC"]["episodes"]
    text = (
        f"Boxes opened of {n}, by training seed: "
        + "; ".join(
            f"{name} {spread(r['opened'])}"
            + (f" (the paper {PAPER_BOXES[name]})" if name in PAPER_BOXES else "")
            for name, r in rows.items()
        )
        + ". "
    )
    tric = rows["TRIC"]["opened"]
    if min(tric) >= BOX_TARGET:
        text += f"TRIC opens at least {BOX_TARGET} with every seed, as the paper's 24. "
    else:
        text += (
            f"TRIC misses the design's {BOX_TARGET} with {sum(o < BOX_TARGET for o in tric)} of "
            f"{len(tric)} seeds (at worst {min(tric)}). "
        )
    best_dpl = max(max(rows["DPL joint space"]["opened"]), max(rows["DPL finger space"]["opened"]))
    text += (
        "Both DPL variants open fewer boxes than TRIC with every seed, as in the paper."
        if best_dpl < min(tric)
        else f"A DPL variant opens as many as {best_dpl} with one seed, not far below TRIC, "
        "unlike the paper."
    )
    return text
