"""Table 1, spheres: the teacher and TRIC (K = 30) on the 15 sphere test situations."""

from tric_control.experiments.paper import PAPER_REPORTS, PAPER_TEACHER, PAPER_TRIC
from tric_control.experiments.rows import grasp_result, grasp_rows, spread
from tric_control.experiments.runner import Runner
from tric_control.experiments.targets import MARGIN_TO_TEACHER, PAPER_PROTOCOL, PAPER_RUN

#: The experiment's heading in the report and the log.
TITLE = (
    "Spheres: the teacher and TRIC K = 30 (three groups: each the model chosen among its "
    "candidates) on the 15 sphere test situations."
)


def run(runner: Runner) -> dict:
    """The experiment's rows, table, figure(s), the paper's numbers and the discussion."""
    rows = grasp_rows(
        runner,
        runner.situations("sphere_test"),
        {
            "TRIC K = 30": dict(name="sphere_k30", bags="sphere"),
            PAPER_PROTOCOL: dict(name="sphere_k30", bags="sphere", **PAPER_RUN),
        },
    )
    return grasp_result(rows, "Table 1: spheres", PAPER_REPORTS["table1"], discussion(rows))


def discussion(rows: dict) -> str:
    teacher, tric = rows["teacher"], rows["TRIC K = 30"]
    n = tric["episodes"]
    seeds = tric["seeds"]
    gaps = [r["cost_mean"] - teacher["cost_mean"] for r in seeds.values()]
    text = (
        f"Over the groups {'/'.join(map(str, seeds))}, TRIC's mean grasp cost is "
        f"{spread([r['cost_mean'] for r in seeds.values()], '.3f')} against our teacher's "
        f"{teacher['cost_mean']:.3f} +- {teacher['cost_std']:.3f}; the gaps "
        f"{'/'.join(format(g, '+.3f') for g in gaps)} (the design allows {MARGIN_TO_TEACHER}; the "
        f"paper's gap is {PAPER_TRIC - PAPER_TEACHER:+.2f}). Good grasps {spread(tric['good'])} "
        f"of {n}, lifted {spread(tric['lift'])}, collisions "
        f"{'/'.join(map(str, tric['collisions']))}. "
    )
    shortfalls = [
        f"group {seed}"
        for seed, r in seeds.items()
        if r["cost_mean"] - teacher["cost_mean"] > MARGIN_TO_TEACHER
        or r["good"] < n
        or r["lift"] < n
        or r["collisions"]
    ]
    text += (
        f"We fall short of the paper with {', '.join(shortfalls)}."
        if shortfalls
        else "Every group reproduces the paper's result: TRIC grasps unseen sphere positions about "
        "as well as its teacher."
    )
    if tric["cost_mean"] < PAPER_TRIC and teacher["cost_mean"] < PAPER_TEACHER:
        text += (
            " Both our costs are lower than the paper's, but our grasp cost is our own metric "
            "(tric_sim.physics.metrics, docs/metrics.md), not the paper's (Dragiev et al. 2011), "
            "so only the gap to the teacher compares."
        )
    return text
