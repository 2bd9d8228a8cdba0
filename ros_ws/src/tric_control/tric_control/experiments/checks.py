"""tric-experiments --check: the experiments' results (their JSON) against the design's targets
(targets.py, docs/design.md section 5), each target for every group (TRIC: the model chosen among
a group's candidates; DPL: one seed).

Each check is one target of one experiment: its text, the measured value of each group, and whether
every group meets it. An experiment without a target (fig8, table2, fig9: curves to look at) has no
check; one whose JSON is missing, or holds no rows, is skipped.
"""

import math
from dataclasses import dataclass

from tric_control.experiments.targets import (
    BOX_TARGET,
    COSINE_TARGET,
    CYLINDER_TARGETS,
    FALLING_TARGET,
    MARGIN_TO_TEACHER,
    PAPER_PROTOCOL,
    REST_TARGET,
    SLOW_COSINE_TARGET,
    WEIGHTED_COSINE_TARGET,
)
from tric_sim.physics.metrics import GOOD_GRASP

#: How far a measured joint may go past its limit, rad (docs/design.md section 6).
OVERSHOOT_LIMIT = 0.01
#: Table 4: training boxes TRIC reproduces of 10 (docs/design.md section 5).
BOX_TRAINING_TARGET = 9


@dataclass(frozen=True)
class Check:
    """One target of one experiment. measured: the value of each seed (or of each model) as text."""

    experiment: str
    target: str
    measured: list
    met: bool


def check_results(results: dict) -> list:
    """The checks ([Check]) of results ({experiment name: its JSON as a dict}), in the order of
    CHECKERS; experiments without targets or not in results give none."""
    checks = []
    for name, checker in CHECKERS.items():
        if "rows" in results.get(name, {}):
            checks.extend(checker(results[name]["rows"]))
    return checks


def check_table(checks: list) -> str:
    """The checks as a table: experiment, target, each seed's value, met or MISSED."""
    lines = [f"{'experiment':10s} {'met':6s} {'target':68s} measured (groups 0/100/200)"]
    for check in checks:
        lines.append(
            f"{check.experiment:10s} {'yes' if check.met else 'MISSED':6s} {check.target:68s} "
            + "/".join(check.measured)
        )
    met = sum(check.met for check in checks)
    lines.append(f"{met} of {len(checks)} targets met")
    return "\n".join(lines)


def _seeds(row: dict) -> list:
    """A seeded row's per-seed rows, in seed order (JSON keys are strings)."""
    return [row["seeds"][seed] for seed in sorted(row["seeds"], key=int)]


def _check(experiment, target, values, meets, fmt) -> Check:
    """A Check of values (one per seed) against meets(value) -> bool."""
    return Check(experiment, target, [format(v, fmt) for v in values], all(map(meets, values)))


def _rest(experiment: str, rows: list, done_key: str) -> Check:
    """The share of each seed's episodes that did their task and came to rest (rows: one per
    seed, each over every set of the experiment)."""
    shares = [
        sum(r["at_rest"] for r in seed_rows) / max(1, sum(r[done_key] for r in seed_rows))
        for seed_rows in rows
    ]
    return _check(
        experiment,
        f"of the episodes that did their task, >= {REST_TARGET:.0%} at rest",
        shares,
        lambda share: share >= REST_TARGET,
        ".0%",
    )


def _every(experiment: str, label: str, seeds: list, key: str, what: str) -> Check:
    """That every episode of each seed's row counts in key (its share of the episodes is 1)."""
    return _check(
        experiment,
        f"{label}: {what}",
        [row[key] / row["episodes"] for row in seeds],
        lambda share: share == 1,
        ".0%",
    )


def _grasp_rows(experiment: str, rows: dict, label: str) -> list:
    """A grasp row's checks shared by the grasp experiments: every grasp good and lifted."""
    seeds = _seeds(rows[label])
    return [
        _every(experiment, label, seeds, "good", f"every grasp good (< {GOOD_GRASP})"),
        _every(experiment, label, seeds, "lift", "every grasped object lifted"),
    ]


def table1_checks(rows: dict) -> list:
    teacher = rows["teacher"]["cost_mean"]
    seeds = _seeds(rows["TRIC K = 30"])
    return [
        _check(
            "table1",
            f"TRIC within {MARGIN_TO_TEACHER} of the teacher's mean cost",
            [row["cost_mean"] - teacher for row in seeds],
            lambda gap: gap <= MARGIN_TO_TEACHER,
            "+.3f",
        ),
        *_grasp_rows("table1", rows, "TRIC K = 30"),
        _rest("table1", [[row] for row in seeds], "good"),
    ]


def table3_checks(rows: dict) -> list:
    cost, good, lifted = CYLINDER_TARGETS
    checks = []
    # the paper's protocol is reported beside ours, not held to the design's targets
    tric = [label for label in rows if label.startswith("TRIC K = 30") and label != PAPER_PROTOCOL]
    for label in tric:
        seeds = _seeds(rows[label])
        checks.append(
            Check(
                "table3",
                f"{label}: mean cost <= {cost}, >= {good} good, >= {lifted} lifted",
                [f"{r['cost_mean']:.3f},{r['good']},{r['lift']}" for r in seeds],
                all(
                    r["cost_mean"] <= cost and r["good"] >= good and r["lift"] >= lifted
                    for r in seeds
                ),
            )
        )
    k0 = _seeds(rows["TRIC K = 0"])
    k30 = _seeds(rows["TRIC K = 30"])
    checks.append(
        _check(
            "table3",
            "K = 30 beats K = 0 (its mean cost lower)",
            [b["cost_mean"] - a["cost_mean"] for a, b in zip(k0, k30)],
            lambda difference: difference < 0,
            "+.3f",
        )
    )
    by_seed = zip(*(_seeds(rows[label]) for label in tric))
    checks.append(_rest("table3", [list(seed_rows) for seed_rows in by_seed], "good"))
    return checks


def exp4_checks(rows: dict) -> list:
    seeds = _seeds(rows["TRIC"])
    return [
        _check(
            "exp4",
            "TRIC: no collision",
            [row["collisions"] for row in seeds],
            lambda collisions: collisions == 0,
            "d",
        ),
        _every("exp4", "TRIC", seeds, "good", f"every grasp good (< {GOOD_GRASP})"),
    ]


def table4_checks(rows: dict) -> list:
    checks = []
    for label, target in (
        ("TRIC", BOX_TARGET),
        ("TRIC (val)", BOX_TARGET),
        ("TRIC (train)", BOX_TRAINING_TARGET),
    ):
        if label in rows:
            checks.append(
                _check(
                    "table4",
                    f"{label}: >= {target} of {rows[label]['episodes']} boxes opened",
                    rows[label]["opened"],
                    lambda opened, target=target: opened >= target,
                    "d",
                )
            )
    dpl = [rows[label]["opened"] for label in ("DPL joint space", "DPL finger space")]
    checks.append(
        _check(
            "table4",
            "both DPL variants open fewer boxes than TRIC",
            [max(d) - t for d, t in zip(zip(*dpl), rows["TRIC"]["opened"])],
            lambda difference: difference < 0,
            "+d",
        )
    )
    labels = [label for label in ("TRIC", "TRIC (val)", "TRIC (train)") if label in rows]
    by_seed = zip(*(_seeds(rows[label]) for label in labels))
    checks.append(_rest("table4", [list(seed_rows) for seed_rows in by_seed], "opened"))
    return checks


def analysis_checks(rows: dict) -> list:
    checks = []
    for task, by_seed in rows.items():
        numbers = [by_seed[seed] for seed in sorted(by_seed, key=int)]
        targets = [
            ("cosine_weighted", "L_g cosine weighted by |dq|", WEIGHTED_COSINE_TARGET, -1),
            ("cosine_moving", "L_g cosine over the moving steps", COSINE_TARGET, -1),
            ("falls", "f falls on the steps >= 0.01 rad", FALLING_TARGET, 1),
        ]
        if task == "box":
            targets.append(
                ("cosine_slow", "L_g cosine over the slow steps", SLOW_COSINE_TARGET, -1)
            )
        for key, text, bound, sign in targets:
            checks.append(
                _check(
                    "analysis",
                    f"{task}: {text} {'<=' if sign < 0 else '>='} {bound}",
                    [n[key] for n in numbers],
                    lambda value, bound=bound, sign=sign: (
                        math.isfinite(value) and sign * (value - bound) >= 0
                    ),
                    ".3f",
                )
            )
    return checks


def exp5_checks(rows: dict) -> list:
    """Issue 26's safety targets over every perturbed episode (size > 0), for each agent and seed:
    no joint more than 0.01 rad past its limit, and no grasp trial colliding (the table is the only
    avoided body of a grasp scene). The box pushes' collisions may be with the box body as well as
    the table, so they are reported in the table, not checked here."""
    checks = []
    for label, row in rows.items():
        seeds = list(row["seeds"].values())
        checks.append(
            _check(
                "exp5",
                f"{label}: perturbed, no joint > {OVERSHOOT_LIMIT} rad past its limit",
                [max(c["max_overshoot"] for c in _perturbed(seed)) for seed in seeds],
                lambda overshoot: overshoot <= OVERSHOOT_LIMIT,
                ".4f",
            )
        )
        checks.append(
            _check(
                "exp5",
                f"{label}: perturbed grasps, no collision with the table",
                [sum(c["collisions"] for c in _perturbed(seed, "box push")) for seed in seeds],
                lambda collisions: collisions == 0,
                "d",
            )
        )
    return checks


def _perturbed(cells: dict, leave_out: str = "") -> list:
    """The perturbed cells (size > 0) of an exp5 seed's {family: {size: cell}}, but leave_out's."""
    return [
        cell
        for family, sizes in cells.items()
        if family != leave_out
        for size, cell in sizes.items()
        if size != "0"
    ]


#: Experiment name -> its checks from its rows.
CHECKERS = {
    "table1": table1_checks,
    "table3": table3_checks,
    "exp4": exp4_checks,
    "table4": table4_checks,
    "exp5": exp5_checks,
    "analysis": analysis_checks,
}
