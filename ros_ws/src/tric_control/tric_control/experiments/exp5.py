"""Experiment 5 (ours; the paper argues it in Sec. 5.4 and Prop. 1 and 2 without a number): TRIC,
DPL in joint space and the teacher when the world does not hold still. Each of 10 test situations
is run unperturbed, pushed (three sizes), with its grasp target jumping sideways mid-approach (2, 5
and 10 cm) or drifting at 2 cm/s, and from random starts (three radii); each of 10 test boxes is
pushed with the finger under the lip (three sizes). The perturbations are
tric_sim.world.perturbation_trials', acted by the simulator node (tric_sim.world.perturbations)."""

import math
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tric_control.evaluation.records import report  # noqa: E402
from tric_control.experiments.runner import SEEDS, Runner  # noqa: E402
from tric_sim.tools.output_files import atomic_path  # noqa: E402
from tric_sim.world import situations  # noqa: E402
from tric_sim.world.perturbation_trials import PERTURB_AT_S, Trial  # noqa: E402

#: The experiment's heading in the report and the log.
TITLE = (
    "Stability: pushes, a target that jumps or drifts, and random starts, on 10 sphere and 10 box "
    "test situations; TRIC and DPL in joint space with three groups each, and the teacher."
)

#: Situations per trial.
COUNT = 10
#: Each family's trials, in growing size; size 0 is the unperturbed situation. Units: push and
#: start rad (norm over the arm's joints), jump m, drift m/s.
FAMILIES = {
    "push": [Trial("push", size) for size in (0.1, 0.2, 0.4)],
    "jump": [Trial("jump", size) for size in (0.02, 0.05, 0.10)],
    "drift": [Trial("drift", 0.02)],
    "start": [Trial("start", size) for size in (0.1, 0.2, 0.4)],
}
#: The box trials: pushes with the finger under the lip.
BOX_FAMILIES = {"box push": [Trial("push", size) for size in (0.1, 0.2, 0.4)]}
#: Success in at least this many of COUNT counts as holding up.
HOLDS = 8
UNITS = {"push": "rad", "jump": "m", "drift": "m/s", "start": "rad", "box push": "rad"}
#: Runner.model's arguments of each agent, by task.
AGENTS: dict[str, dict[str, dict[str, Any]]] = {
    "grasp": {
        "TRIC": dict(name="sphere_k30", bags="sphere"),
        "DPL joint space": dict(name="sphere_dpl_joint", bags="sphere", kind="dpl_joint"),
    },
    "open_box": {
        "TRIC": dict(name="box_k30", bags="box"),
        "DPL joint space": dict(name="box_dpl_joint", bags="box", kind="dpl_joint"),
    },
}
#: The jolt of the trace figure (f and the joint speed through it): TRIC, first group, on this
#: situation, jolted by this much (rad) half a second after it first came to rest and gripped (or at
#: the task's usual time when it does not come to rest). A jolt, not a push: at rest the position
#: hold takes a push over 0.1 s back as it comes (docs/decisions/perturbations.md).
TRACE = ("sphere_test_00", 0.4)
#: The trace's episodes' budget, ticks: long enough to rest, be jolted, and rest again.
TRACE_STEPS = 2500


def run(runner: Runner) -> dict:
    """The experiment's rows, table, figures, the paper's numbers (none) and the discussion."""
    robot = runner.robot
    rows: dict[str, dict] = {}
    for dataset, families in (("sphere_test", FAMILIES), ("box_test", BOX_FAMILIES)):
        base = runner.situations(dataset)[:COUNT]
        trials = [(family, trial) for family, chosen in families.items() for trial in chosen]
        chosen = base + [trial.apply(s, robot) for _, trial in trials for s in base]
        task = base[0].task
        agents = {"teacher": None, **AGENTS[task]}
        for label, model in agents.items():
            by_seed = (
                {"-": runner.evaluate(chosen, None, f"teacher, {dataset} perturbed")}
                if model is None
                else runner.over_seeds(chosen, f"{label}, {dataset} perturbed", **model)
            )
            row = rows.setdefault(label, {"seeds": {}})
            for seed, records in by_seed.items():
                row["seeds"].setdefault(str(seed), {}).update(_cells(records, families, len(base)))
    trace = _trace(runner)
    figures = {"exp5.png": _success_figure(rows), "exp5_push.png": _trace_figure(trace)}
    for name, figure in figures.items():
        figure.tight_layout()
        with atomic_path(runner.out / name) as temporary:
            figure.savefig(temporary, dpi=110)
        plt.close(figure)
    return {
        "rows": rows,
        "table": table(rows),
        "figures": list(figures),
        "trace": trace,
        "paper": "no number: Sec. 5.4 argues that a minimum of f attracts the controller from "
        "any start (Prop. 1, 2), and that TRIC reacts where DPL replays",
        "discussion": discussion(rows, trace),
    }


def _cells(records, families: dict, count: int) -> dict:
    """{family: {size: cell}} of one agent and seed, records in run()'s order (the unperturbed
    situations, then each trial's); each family starts with size 0, the unperturbed run."""
    blocks = [records[k : k + count] for k in range(0, len(records), count)]
    unperturbed, *perturbed = blocks
    cells, k = {}, 0
    for family, trials in families.items():
        cells[family] = {"0": _cell(unperturbed)}
        for trial in trials:
            cells[family][f"{trial.size:g}"] = _cell(perturbed[k])
            k += 1
    return cells


def _cell(records) -> dict:
    costs = [r.grasp_cost for r in records if math.isfinite(r.grasp_cost)]
    return {
        "ok": sum(r.success for r in records),
        "episodes": len(records),
        "cost_mean": float(np.mean(costs)) if costs else math.nan,
        "collisions": sum(r.collided for r in records),
        "max_overshoot": max(r.max_joint_overshoot for r in records),
        "records": report(records)["episodes"],
    }


def largest_holding(cells: dict) -> float:
    """The largest size of a family's cells ({size: cell}) up to which every size succeeds in at
    least HOLDS of its episodes; 0 if the first perturbed size fails (nan if even 0 does)."""
    held = math.nan
    for size, cell in sorted(cells.items(), key=lambda item: float(item[0])):
        if cell["ok"] < HOLDS * cell["episodes"] / COUNT:
            break
        held = float(size)
    return held


def held_text(cells: dict) -> str:
    """largest_holding of a family's cells as text: "none" when even the unperturbed run fails,
    ">= SIZE" when the largest size tried holds (the limit lies beyond it)."""
    held = largest_holding(cells)
    if math.isnan(held):
        return "none"
    largest = max(float(size) for size in cells)
    return f">={held:g}" if held == largest else f"{held:g}"


def table(rows: dict) -> str:
    families = [*FAMILIES, *BOX_FAMILIES]
    lines = [
        f"{'agent':16s} {'seed':>4s} "
        + " ".join(f"{family + ' (' + UNITS[family] + ')':>26s}" for family in families)
    ]
    for label, row in rows.items():
        for seed, cells in row["seeds"].items():
            lines.append(
                f"{label:16s} {seed:>4s} "
                + " ".join(f"{_successes(cells.get(family, {})):>26s}" for family in families)
            )
    lines += ["", f"largest size succeeding in at least {HOLDS} of {COUNT}:"]
    for label, row in rows.items():
        for seed, cells in row["seeds"].items():
            lines.append(
                f"{label:16s} {seed:>4s} "
                + ", ".join(
                    f"{family} {held_text(cells[family])}" for family in families if family in cells
                )
            )
    worst = max(
        cell["max_overshoot"]
        for row in rows.values()
        for cells in row["seeds"].values()
        for family in cells.values()
        for cell in family.values()
    )
    collisions = sum(
        cell["collisions"]
        for row in rows.values()
        for cells in row["seeds"].values()
        for family in cells.values()
        for size, cell in family.items()
        if size != "0"
    )
    lines.append(
        f"\nperturbed episodes: {collisions} collisions; joints at most {worst:.4f} rad past a "
        "limit"
    )
    return "\n".join(lines)


def _successes(cells: dict) -> str:
    """'size:ok' for each size of a family, e.g. '0:10 0.1:9 0.2:7 0.4:3'."""
    return " ".join(f"{size}:{cell['ok']}" for size, cell in cells.items()) or "-"


def trace_text(trace: dict) -> str:
    """What the trace of TRACE's jolt shows: when TRIC first came to rest and gripped, f's rise at
    the jolt, how soon after it f is back below its value before the jolt (counted from f's peak:
    a jolt takes a few ticks to throw the hand, and f may first dip), and whether the controller
    left rest, descended, and came to rest and gripped again."""
    t, f = (np.asarray(trace[key], dtype=float) for key in ("t", "f"))
    phases, at = trace["phase"], trace["push_at_s"]
    before = f[t <= at][np.isfinite(f[t <= at])]
    text = f"Through the jolt of {trace['situation']} (TRIC, first group): "
    if trace["rested_at_s"] is None:
        text += "it did not come to rest before the jolt (jolted at the usual time); "
    else:
        text += f"it came to rest and gripped at {trace['rested_at_s']:.2f} s; "
    rests = [
        t[k]
        for k in range(1, len(t))
        if phases[k] != "descending" and phases[k - 1] == "descending"
    ]
    again = [r for r in rests if r > at]
    after = (t > at) & np.isfinite(f)
    if before.size and after.any():
        peak = np.flatnonzero(after)[np.argmax(f[after])]
        back = t[after & (t > t[peak]) & (f < before[-1])]
        text += (
            f"jolted at {at:.2f} s, f rises from {before[-1]:.1f} to {f[peak]:.1f} as the "
            "controller leaves rest, and is back below "
            + (f"{before[-1]:.1f} {back[0] - at:.2f} s after the jolt" if back.size else "never")
            + "; "
        )
    text += (
        f"it comes to rest and grips again at {again[0]:.2f} s"
        if again
        else "it does not come to rest again before its budget"
    )
    return (
        text
        + f" (the grasp {'a success' if trace['success'] else 'a failure'}, {trace['outcome']})."
    )


def discussion(rows: dict, trace: dict | None = None) -> str:
    tric, dpl = rows["TRIC"]["seeds"], rows["DPL joint space"]["seeds"]
    perturbed = [*FAMILIES, *BOX_FAMILIES]

    def total(cells):
        return sum(
            cell["ok"]
            for family in perturbed
            for size, cell in cells.get(family, {}).items()
            if size != "0"
        )

    episodes = sum(
        cell["episodes"]
        for family in perturbed
        for size, cell in next(iter(tric.values())).get(family, {}).items()
        if size != "0"
    )
    tric_totals = [total(cells) for cells in tric.values()]
    dpl_totals = [total(cells) for cells in dpl.values()]
    teacher_total = total(rows["teacher"]["seeds"]["-"])
    text = (
        f"Of {episodes} perturbed episodes, TRIC succeeds in "
        f"{'/'.join(map(str, tric_totals))} (groups {', '.join(tric)}), DPL in joint space in "
        f"{'/'.join(map(str, dpl_totals))}, the teacher in {teacher_total}. "
    )
    if min(tric_totals) > max(dpl_totals):
        text += "TRIC recovers better than DPL with every pair of seeds. "
    else:
        text += (
            "TRIC does not recover better than DPL with every pair of seeds: its worst seed "
            f"({min(tric_totals)}) is not above DPL's best ({max(dpl_totals)}). "
        )
    unperturbed = [
        cells["push"]["0"]["ok"] + cells["box push"]["0"]["ok"] for cells in dpl.values()
    ]
    if max(unperturbed) < COUNT:  # fewer than half of the 2 * COUNT
        text += (
            f"DPL fails most situations unperturbed already ({'/'.join(map(str, unperturbed))} of "
            f"{2 * COUNT} spheres and boxes), so its rows say more about replaying joint motions "
            "on test situations than about recovering. "
        )
    text += (
        '(">=" marks the largest size tried: the limit lies beyond it; "none": the agent fails in '
        f"more than {COUNT - HOLDS} of {COUNT} unperturbed.) "
    )
    for family in perturbed:
        held = {
            label: "/".join(held_text(cells[family]) for cells in row["seeds"].values())
            for label, row in rows.items()
            if family in next(iter(row["seeds"].values()))
        }
        text += (
            f"Largest {family} ({UNITS[family]}) still succeeding in {HOLDS} of {COUNT}: "
            + "; ".join(f"{label} {values}" for label, values in held.items())
            + ". "
        )
    teacher = rows["teacher"]["seeds"]["-"]
    if "jump" in teacher:
        text += (
            f"The teacher plans its grasp once, from the situation: a target that jumps 10 cm "
            f"leaves it {teacher['jump']['0.1']['ok']} of {COUNT}, where TRIC, which reads the "
            "target's pose every tick, keeps "
            f"{'/'.join(str(cells['jump']['0.1']['ok']) for cells in tric.values())}. "
        )
    return text + (trace_text(trace) if trace else "")


def _trace(runner: Runner) -> dict:
    """f, the arm's joint speed and the controller's phase through TRACE's jolt, TRIC chosen from
    the first group, offline (the same controller core as the node's): the situation is run once
    to find when TRIC first comes to rest, then jolted half a second after that."""
    from tric_control.evaluation.offline import OfflineEvaluator

    name, size = TRACE
    nominal = situations.find_situation(name, workspace=runner.profile.workspace)
    model = runner.model(**AGENTS["grasp"]["TRIC"], seed=SEEDS[0])
    evaluator = OfflineEvaluator("grasp", model, TRACE_STEPS, robot=runner.profile.spec)
    rested: list[float] = []
    trace: dict[str, list] = {"t": [], "f": [], "speed": [], "phase": []}

    def first_rest(world, step):
        if step is not None and step.tick is None and not rested:
            rested.append(world.elapsed_s)

    def on_period(world, step):
        _, velocity = world.joint_state()
        trace["t"].append(world.elapsed_s)
        trace["f"].append(step.tick.value if step.tick is not None else math.nan)
        trace["speed"].append(float(np.linalg.norm(velocity[runner.robot.arm_indices])))
        trace["phase"].append(
            "descending" if step.tick is not None else "gripping" if step.gripping else "at rest"
        )

    try:
        evaluator.run(nominal, on_period=first_rest)
        at_s = rested[0] + 0.5 if rested else None
        situation = Trial("jolt", size, at_s).apply(nominal, runner.robot)
        record = evaluator.run(situation, on_period=on_period)
    finally:
        evaluator.close()
    return {
        **trace,
        "situation": situation.name,
        "rested_at_s": rested[0] if rested else None,
        "push_at_s": PERTURB_AT_S["grasp"] if at_s is None else at_s,
        "success": bool(record.success),
        "outcome": record.outcome,
    }


def _success_figure(rows: dict):
    families = [*FAMILIES, *BOX_FAMILIES]
    figure, axes = plt.subplots(1, len(families), figsize=(3.0 * len(families), 3.0), sharey=True)
    for axis, family in zip(axes, families):
        for label, row in rows.items():
            seeds = [cells[family] for cells in row["seeds"].values() if family in cells]
            if not seeds:
                continue
            sizes = [float(size) for size in seeds[0]]
            ok = np.array([[cell["ok"] for cell in cells.values()] for cells in seeds])
            line = axis.plot(sizes, ok.mean(axis=0), marker="o", label=label)[0]
            if len(seeds) > 1:
                axis.fill_between(
                    sizes, ok.min(axis=0), ok.max(axis=0), color=line.get_color(), alpha=0.2
                )
        axis.set_title(family)
        axis.set_xlabel(UNITS[family])
        axis.axhline(HOLDS, color="gray", linewidth=0.6, linestyle=":")
    axes[0].set_ylabel(f"successes of {COUNT} (band: range over seeds)")
    axes[-1].legend(fontsize=7)
    return figure


def _trace_figure(trace: dict):
    figure, axis = plt.subplots(figsize=(6.0, 3.2))
    t = np.asarray(trace["t"])
    axis.plot(t, trace["f"], color="tab:blue")
    axis.set_xlabel("simulated time (s)")
    axis.set_ylabel("f (TRIC's value)", color="tab:blue")
    axis.axvline(trace["push_at_s"], color="gray", linestyle="--", linewidth=0.8)
    phases = np.asarray(trace["phase"])
    for phase, colour in (("gripping", "tab:green"), ("at rest", "tab:gray")):
        axis.fill_between(
            t,
            0,
            1,
            where=phases == phase,
            color=colour,
            alpha=0.15,
            transform=axis.get_xaxis_transform(),
            label=phase,
        )
    axis.legend(fontsize=7, loc="upper right")
    speed = axis.twinx()
    speed.plot(t, trace["speed"], color="tab:orange", linewidth=0.8)
    speed.set_ylabel("arm joint speed (rad/s)", color="tab:orange")
    axis.set_title(
        f"{trace['situation']}: f and speed through the jolt "
        f"({'success' if trace['success'] else 'failure'}, {trace['outcome']})",
        fontsize=9,
    )
    return figure
