"""Evaluation records, summaries and tables. ROS-free.

An evaluation runs one agent (the teacher, or a model file run by the controller) on a list of
situations and judges each episode with the hidden task metrics (tric_sim.physics.metrics): the
grasp cost and lift test for grasps, the lid angle for boxes, the closest approach to the avoided
geometry and the smallest joint-limit margin. This module holds what that produces: one
EpisodeRecord per episode, their summary, the table printed to stdout and the JSON file.
"""

import collections
import json
import math
import pathlib
from dataclasses import asdict, dataclass, fields
from typing import Any

import numpy as np

from tric_sim.physics.metrics import GOOD_GRASP, LID_OPEN_ANGLE
from tric_sim.tools.output_files import write_text_atomic


@dataclass
class EpisodeRecord:
    """One evaluated episode. Distances in m, angles and margins in rad, times in s.

    grasp_cost, lift_passed: grasps only (NaN / None otherwise); lid_angle: boxes only (NaN
    otherwise). min_distance: the smallest signed distance between the robot and the table,
    obstacles and box body over the episode, as the simulator measured it (negative: penetration);
    collided: it went below zero. min_joint_margin: the smallest distance of a commanded joint's
    measured position to its limit (NaN for the teacher, whose episodes the controller does not
    see). max_joint_overshoot: the largest distance a measured joint (arm, hand or the lid's hinge)
    went past its limit, as the simulator measured it (0: none did). outcome: how the episode ended
    ("converged", "step_budget", "demonstrated", "failed", ...). message: why, when it failed.
    failure: why the task failed, by the hidden metrics' failure class (tric_sim.physics.metrics:
    "palm off target", "under the lip", ...; "collision" whenever the robot collided, even in a
    success; "" for a success without collision, or a run that failed).
    """

    situation: str
    task: str
    agent: str
    success: bool
    grasp_cost: float
    lift_passed: object
    lid_angle: float
    min_distance: float
    collided: bool
    min_joint_margin: float
    steps: int
    wall_time_s: float
    outcome: str
    message: str = ""
    max_joint_overshoot: float = math.nan
    failure: str = ""

    @property
    def failed(self) -> bool:
        """The episode could not be run to its end (as opposed to ending badly)."""
        return self.outcome == "failed"


def unjudged_fields(situation, agent: str) -> dict:
    """The fields of an episode's EpisodeRecord before the hidden metrics have judged it (what a
    run that fails keeps): not a success, no metrics, no steps. The caller adds the times and the
    outcome."""
    return dict(
        situation=situation.name,
        task=situation.task,
        agent=agent,
        success=False,
        grasp_cost=math.nan,
        lift_passed=None,
        lid_angle=math.nan,
        min_distance=math.nan,
        collided=False,
        min_joint_margin=math.nan,
        steps=0,
    )


def task_done(record: EpisodeRecord) -> bool:
    """Whether the episode did its task by the hidden metrics: a good grasp (cost below
    GOOD_GRASP) or an opened box (lid beyond LID_OPEN_ANGLE), collisions aside."""
    if record.task == "grasp":
        return bool(record.grasp_cost < GOOD_GRASP)
    return bool(record.lid_angle > LID_OPEN_ANGLE)


def evaluated_task(situations, jobs: int) -> str:
    """The one task of the situations an evaluation runs in jobs processes; ValueError if they mix
    tasks or jobs is below 1."""
    tasks = {s.task for s in situations}
    if len(tasks) != 1:
        raise ValueError(
            f"the situations mix tasks ({', '.join(sorted(tasks))}): evaluate one task at a time"
        )
    if jobs < 1:
        raise ValueError(f"jobs must be at least 1, not {jobs}")
    return tasks.pop()


def _mean(values) -> float:
    values = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.mean(values)) if values else math.nan


def _max(values) -> float:
    values = [v for v in values if v is not None and math.isfinite(v)]
    return float(np.max(values)) if values else math.nan


def summarize(records) -> dict:
    """Means, extremes and counts over the records (NaN where a quantity does not apply)."""
    grasps = [r for r in records if r.task == "grasp"]
    boxes = [r for r in records if r.task == "open_box"]
    distances = [r.min_distance for r in records if math.isfinite(r.min_distance)]
    margins = [r.min_joint_margin for r in records if math.isfinite(r.min_joint_margin)]
    return {
        "episodes": len(records),
        "failed_runs": sum(r.failed for r in records),
        "successes": sum(bool(r.success) for r in records),
        "grasp_cost_mean": _mean(r.grasp_cost for r in grasps),
        "grasp_cost_max": _max(r.grasp_cost for r in grasps),
        "good_grasps": sum(r.grasp_cost < GOOD_GRASP for r in grasps),
        "lift_passed": sum(r.lift_passed is True for r in grasps),
        "boxes_opened": sum(r.lid_angle > LID_OPEN_ANGLE for r in boxes),
        "lid_angle_mean": _mean(r.lid_angle for r in boxes),
        "collisions": sum(bool(r.collided) for r in records),
        "min_distance": float(min(distances)) if distances else math.nan,
        "min_joint_margin": float(min(margins)) if margins else math.nan,
        "max_joint_overshoot": _max(r.max_joint_overshoot for r in records),
        "steps_mean": _mean(r.steps for r in records),
        "converged": sum(r.outcome == "converged" for r in records),
        "step_budget": sum(r.outcome == "step_budget" for r in records),
        "done": sum(task_done(r) for r in records),
        "done_converged": sum(task_done(r) and r.outcome == "converged" for r in records),
        "wall_time_s_mean": _mean(r.wall_time_s for r in records),
        "failures": dict(
            collections.Counter(r.failure for r in records if r.failure).most_common()
        ),
    }


def _cell(value, fmt: str) -> str:
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "yes" if value else "no"
    if isinstance(value, float) and not math.isfinite(value):
        return "-"
    return format(value, fmt)


def table(records, title: str = "") -> str:
    """A fixed-width table of the records, with a summary line."""
    header = (
        f"{'situation':22s} {'agent':10s} {'ok':>3s} {'cost':>6s} {'lift':>4s} {'lid':>5s} "
        f"{'min d (mm)':>10s} {'margin':>6s} {'over':>5s} {'steps':>5s} {'wall s':>6s}  "
        f"{'outcome':12s} failure"
    )
    lines = [title] if title else []
    lines += [header, "-" * len(header)]
    for r in records:
        lines.append(
            f"{r.situation[:22]:22s} {r.agent[:10]:10s} {_cell(bool(r.success), ''):>3s} "
            f"{_cell(r.grasp_cost, '.3f'):>6s} {_cell(r.lift_passed, ''):>4s} "
            f"{_cell(r.lid_angle, '.2f'):>5s} {_cell(r.min_distance * 1e3, '.1f'):>10s} "
            f"{_cell(r.min_joint_margin, '.3f'):>6s} {_cell(r.max_joint_overshoot, '.3f'):>5s} "
            f"{r.steps:5d} {r.wall_time_s:6.1f}  {r.outcome:12s} "
            f"{'(run failed: ' + r.message + ')' if r.failed else r.failure or '-'}"
        )
    s = summarize(records)
    lines.append("-" * len(header))
    parts = [f"{s['successes']}/{s['episodes']} succeeded"]
    if math.isfinite(s["grasp_cost_mean"]):
        parts.append(
            f"grasp cost mean {s['grasp_cost_mean']:.3f}, max {s['grasp_cost_max']:.3f}, "
            f"{s['good_grasps']} below {GOOD_GRASP}, lift passed {s['lift_passed']}"
        )
    if math.isfinite(s["lid_angle_mean"]):
        parts.append(f"{s['boxes_opened']} boxes opened (lid mean {s['lid_angle_mean']:.2f} rad)")
    parts.append(
        f"{s['collisions']} collisions (closest {_cell(s['min_distance'] * 1e3, '.1f')} mm)"
    )
    if math.isfinite(s["max_joint_overshoot"]):
        parts.append(f"joints at most {s['max_joint_overshoot']:.3f} rad past a limit")
    if s["converged"] or s["step_budget"]:
        parts.append(
            f"{s['converged']} came to rest ({s['done_converged']} of the {s['done']} that did "
            f"the task), {s['step_budget']} spent the step budget"
        )
    if s["failures"]:
        parts.append(
            "failures: " + ", ".join(f"{name} {count}" for name, count in s["failures"].items())
        )
    if s["failed_runs"]:
        parts.append(f"{s['failed_runs']} runs failed")
    lines.append("; ".join(parts))
    return "\n".join(lines)


def _json_safe(value):
    """NaN/inf become null, so the file is strict JSON."""
    if isinstance(value, float) and not math.isfinite(value):
        return None
    if isinstance(value, dict):
        return {k: _json_safe(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_json_safe(v) for v in value]
    return value


def report(records) -> dict:
    """{"summary": ..., "episodes": [...]}: the records and their summary, as JSON-ready data."""
    return {"summary": summarize(records), "episodes": [asdict(r) for r in records]}


def record_from_json(data: dict) -> EpisodeRecord:
    """An EpisodeRecord from its JSON form (report's "episodes"; null floats back to NaN);
    ValueError naming what does not fit."""
    names = {f.name: f for f in fields(EpisodeRecord)}
    if not isinstance(data, dict) or set(data) - set(names):
        raise ValueError(f"not an episode record: {str(data)[:200]}")
    values: dict[str, Any] = {
        k: math.nan if v is None and names[k].type is float else v for k, v in data.items()
    }
    return EpisodeRecord(**values)


def write_json(path, data: dict, replace: bool = True) -> pathlib.Path:
    """Write data to path as strict JSON (NaN and inf as null), atomically (a file that appeared at
    path meanwhile replaced only if replace: tric_sim.tools.output_files.atomic_path); the
    path."""
    return write_text_atomic(path, json.dumps(_json_safe(data), indent=2) + "\n", replace)
