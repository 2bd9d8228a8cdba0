"""Table 3, cylinders: the teacher, TRIC K = 0 and TRIC K = 30."""

from tric_control.experiments.paper import PAPER_REPORTS
from tric_control.experiments.rows import grasp_result, grasp_rows, spread
from tric_control.experiments.runner import Runner
from tric_control.experiments.targets import CYLINDER_TARGETS
from tric_sim import situations

#: The experiment's heading in the report and the log.
TITLE = (
    "Cylinders: the teacher, TRIC K = 0 and K = 30 (three training seeds each) on the 10 "
    "cylinder tests."
)


def run(runner: Runner) -> dict:
    """The experiment's rows, table, figure(s), the paper's numbers and the discussion."""
    models = {
        f"TRIC K = {units}": dict(name=f"cylinder_k{units}", bags="cylinder", hidden_units=units)
        for units in (0, 30)
    }
    rows = grasp_rows(runner, situations.dataset("cylinder_test"), models)
    return grasp_result(rows, "Table 3: cylinders", PAPER_REPORTS["table3"], discussion(rows))


def discussion(rows: dict) -> str:
    teacher, linear, tric = rows["teacher"], rows["TRIC K = 0"], rows["TRIC K = 30"]
    n = tric["episodes"]
    text = (
        f"Our teacher's mean cost is {teacher['cost_mean']:.3f} (the paper's 0.07). TRIC K = 30, "
        f"seeds {'/'.join(map(str, tric['seeds']))}: mean cost "
        f"{spread([r['cost_mean'] for r in tric['seeds'].values()], '.3f')}, good "
        f"{spread(tric['good'])} of {n}, lifted {spread(tric['lift'])} (the paper 0.09). K = 0: "
        f"{spread([r['cost_mean'] for r in linear['seeds'].values()], '.3f')}, good "
        f"{spread(linear['good'])} (the paper 0.19). "
    )
    cost, good, lifted = CYLINDER_TARGETS
    missed = [
        f"seed {seed}"
        for seed, r in tric["seeds"].items()
        if r["cost_mean"] > cost or r["good"] < good or r["lift"] < lifted
    ]
    text += (
        f"Every seed meets the design's targets (mean <= {cost}, >= {good}/{n} good, >= "
        f"{lifted}/{n} lifted). "
        if not missed
        else f"{', '.join(missed)} miss the design's targets (mean <= {cost}, >= {good}/{n} good, "
        f">= {lifted}/{n} lifted). "
    )
    better = [
        seed
        for seed in tric["seeds"]
        if tric["seeds"][seed]["cost_mean"] < linear["seeds"][seed]["cost_mean"]
    ]
    text += (
        "K = 30 beats K = 0 with every seed, as in the paper."
        if len(better) == len(tric["seeds"])
        else f"K = 30 beats K = 0 with seeds {', '.join(map(str, better)) or 'none'} only, unlike "
        "the paper."
    )
    return text
