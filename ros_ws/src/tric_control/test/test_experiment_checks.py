"""tric-experiments --check: hand-made results against the design's targets, at and past each
bound, and the command on a results folder."""

import json
import math

import numpy as np
import pytest

from tric_control.experiments import cli
from tric_control.experiments.checks import check_results, check_table


def grasp_seed(cost, good=10, lift=10, at_rest=0, collisions=0, episodes=10):
    return {
        "cost_mean": cost,
        "good": good,
        "lift": lift,
        "at_rest": at_rest,
        "collisions": collisions,
        "episodes": episodes,
    }


def seeded(*seeds):
    return {"seeds": {str(i): row for i, row in enumerate(seeds)}}


def box_row(opened, at_rest, episodes):
    return {
        "opened": list(opened),
        "episodes": episodes,
        "seeds": {
            str(i): {"opened": o, "at_rest": r, "episodes": episodes}
            for i, (o, r) in enumerate(zip(opened, at_rest))
        },
    }


def by_target(checks):
    return {(c.experiment, c.target): c for c in checks}


def test_table1_gap_to_the_teacher_is_met_within_the_margin_and_missed_past_it():
    rows = {
        "teacher": {"cost_mean": 0.02},
        "TRIC K = 30": seeded(
            grasp_seed(0.0499, at_rest=10),
            grasp_seed(0.049, at_rest=9),
            grasp_seed(0.03, 10, 10, 9),
        ),
    }
    checks = by_target(check_results({"table1": {"rows": rows}}))
    gap = checks[("table1", "TRIC within 0.03 of the teacher's mean cost")]
    assert gap.met and gap.measured == ["+0.030", "+0.029", "+0.010"]
    assert checks[("table1", "of the episodes that did their task, >= 90% at rest")].met
    rows["TRIC K = 30"]["seeds"]["1"] = grasp_seed(0.051, good=9, at_rest=8)
    checks = by_target(check_results({"table1": {"rows": rows}}))
    assert not checks[("table1", "TRIC within 0.03 of the teacher's mean cost")].met
    assert not checks[("table1", "TRIC K = 30: every grasp good (< 0.25)")].met
    assert not checks[("table1", "of the episodes that did their task, >= 90% at rest")].met


def test_table3_needs_every_seed_of_every_draw_and_k30_beating_k0():
    good = grasp_seed(0.12, good=9, lift=8)
    rows = {
        "TRIC K = 0": seeded(*[grasp_seed(0.5)] * 3),
        "TRIC K = 30": seeded(good, good, good),
        "TRIC K = 30, 2nd draw": seeded(good, good, grasp_seed(0.12, good=9, lift=7)),
    }
    checks = check_results({"table3": {"rows": rows}})
    met = {c.target.split(":")[0]: c.met for c in checks}
    assert met["TRIC K = 30"] and not met["TRIC K = 30, 2nd draw"]
    assert met["K = 30 beats K = 0 (its mean cost lower)"]


def test_table4_bounds_dpl_and_rest():
    rows = {
        "TRIC": box_row((23, 24, 25), (23, 24, 25), 25),
        "TRIC (val)": box_row((23, 22, 25), (0, 0, 0), 25),
        "TRIC (train)": box_row((9, 10, 9), (9, 10, 9), 10),
        "DPL joint space": box_row((22, 1, 1), (0, 0, 0), 25),
        "DPL finger space": box_row((0, 23, 0), (0, 0, 0), 25),
    }
    checks = by_target(check_results({"table4": {"rows": rows}}))
    assert checks[("table4", "TRIC: >= 23 of 25 boxes opened")].met
    assert not checks[("table4", "TRIC (val): >= 23 of 25 boxes opened")].met
    assert checks[("table4", "TRIC (train): >= 9 of 10 boxes opened")].met
    dpl = checks[("table4", "both DPL variants open fewer boxes than TRIC")]
    assert dpl.measured == ["-1", "-1", "-24"] and dpl.met
    rest = checks[("table4", "of the episodes that did their task, >= 90% at rest")]
    assert not rest.met  # the validation boxes opened never came to rest


def test_analysis_targets_and_the_box_slow_steps():
    numbers = {"cosine_weighted": -0.9, "cosine_moving": -0.8, "falls": 0.95, "cosine_slow": -0.5}
    rows = {
        "sphere": {"0": dict(numbers), "1": dict(numbers)},
        "box": {"0": dict(numbers), "1": {**numbers, "cosine_slow": -0.8, "falls": math.nan}},
    }
    checks = by_target(check_results({"analysis": {"rows": rows}}))
    assert checks[("analysis", "sphere: L_g cosine weighted by |dq| <= -0.9")].met
    assert checks[("analysis", "sphere: f falls on the steps >= 0.01 rad >= 0.95")].met
    assert ("analysis", "sphere: L_g cosine over the slow steps <= -0.8") not in checks
    assert not checks[("analysis", "box: L_g cosine over the slow steps <= -0.8")].met
    assert not checks[("analysis", "box: f falls on the steps >= 0.01 rad >= 0.95")].met  # NaN
    table = check_table(list(checks.values()))
    assert "MISSED" in table and table.endswith(f"of {len(checks)} targets met")


def test_check_only_reads_a_folder_and_exits_by_the_targets(tmp_path, capsys):
    assert cli.main(["--check-only", "--out", str(tmp_path)]) == 2  # nothing to check
    rows = {
        "teacher": {"cost_mean": 0.02},
        "TRIC K = 30": seeded(*[grasp_seed(0.04, 10, 10, 10)] * 3),
    }
    (tmp_path / "table1.json").write_text(json.dumps({"rows": rows}))
    assert cli.main(["--check-only", "--out", str(tmp_path)]) == 0
    rows["TRIC K = 30"]["seeds"]["2"] = grasp_seed(0.06, 10, 10, 10)
    (tmp_path / "table1.json").write_text(json.dumps({"rows": rows}))
    assert cli.main(["--check-only", "--out", str(tmp_path)]) == 1
    assert "MISSED TRIC within 0.03" in capsys.readouterr().out


def exp5_cells(ok_by_size, collisions=0, overshoot=0.0):
    """{size: cell} of one exp5 family: ok_by_size {size text: successes of 10}."""
    return {
        size: {"ok": ok, "episodes": 10, "collisions": collisions, "max_overshoot": overshoot}
        for size, ok in ok_by_size.items()
    }


def test_exp5_largest_holding_size_and_the_safety_checks():
    from tric_control.experiments.exp5 import held_text, largest_holding

    assert largest_holding(exp5_cells({"0": 10, "0.1": 9, "0.2": 7, "0.4": 9})) == 0.1
    assert held_text(exp5_cells({"0": 10, "0.1": 9, "0.2": 7, "0.4": 9})) == "0.1"
    assert held_text(exp5_cells({"0": 10, "0.1": 8, "0.2": 8})) == ">=0.2"
    assert held_text(exp5_cells({"0": 10, "0.1": 7})) == "0"
    assert held_text(exp5_cells({"0": 7, "0.1": 9})) == "none"
    safe = {"push": exp5_cells({"0": 10, "0.2": 9}), "box push": exp5_cells({"0": 9, "0.2": 9})}
    box_collision = {
        "push": exp5_cells({"0": 10, "0.2": 9}),
        "box push": {"0": safe["box push"]["0"], **exp5_cells({"0.2": 9}, collisions=2)},
    }
    past_limit = {
        "push": {"0": safe["push"]["0"], **exp5_cells({"0.2": 9}, overshoot=0.02, collisions=1)},
        "box push": safe["box push"],
    }
    rows = {"TRIC": {"seeds": {"0": safe, "1": box_collision, "2": past_limit}}}
    checks = by_target(check_results({"exp5": {"rows": rows}}))
    limits = checks[("exp5", "TRIC: perturbed, no joint > 0.01 rad past its limit")]
    assert limits.measured == ["0.0000", "0.0000", "0.0200"] and not limits.met
    table = checks[("exp5", "TRIC: perturbed grasps, no collision with the table")]
    # the box pushes' collisions (the box body, or the table) are not this check's
    assert table.measured == ["0", "0", "1"] and not table.met


def test_report_only_writes_the_report_and_a_results_page_elsewhere(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / "fig8.json").write_text(
        json.dumps(
            {
                "rows": {},
                "table": "the table",
                "paper": "no collision",
                "discussion": "TRIC grasps 5/5/5.",
                "date": "2026-12-03 10:00",
                "wall_s": 1.0,
            }
        )
    )
    page = tmp_path / "docs" / "results.md"
    page.parent.mkdir()
    assert cli.main(["--report-only", "--out", str(out), "--results-page", str(page)]) == 0
    assert "the table" in (out / "REPORT.md").read_text()
    text = page.read_text()
    assert "TRIC grasps 5/5/5." in text and "The paper: no collision." in text
    assert "![fig8](../run/fig8.png)" in text  # the figure linked relative to the page
    assert "# TRIC experiments on the robot tric_arm_hand" in (out / "REPORT.md").read_text()


def _result(discussion: str, robot: str | None) -> str:
    data = {"rows": {}, "table": "t", "paper": "p", "discussion": discussion}
    data.update(date="2026-12-05 10:00", wall_s=1.0, **({"robot": robot} if robot else {}))
    return json.dumps(data)


def test_the_results_page_puts_another_robot_s_results_beside(tmp_path, capsys):
    """--beside DIR: another robot's results folder, a section of its own on the results page
    after the paper's robot's, named by the robot its JSON records; a folder without a report is
    refused, and results that mix robots too."""
    paper, panda = tmp_path / "paper", tmp_path / "panda"
    for folder, robot, text in ((paper, None, "paper robot"), (panda, "panda", "panda robot")):
        folder.mkdir()
        (folder / "fig8.json").write_text(_result(text, robot))
    page = tmp_path / "results.md"
    assert cli.main(["--report-only", "--out", str(panda), "--results-page", str(page)]) == 0
    arguments = ["--report-only", "--out", str(paper), "--results-page", str(page)]
    assert cli.main(arguments + ["--beside", str(panda)]) == 0
    text = page.read_text()
    assert (
        text.index("paper robot") < text.index("## On the robot panda") < text.index("panda robot")
    )
    assert "### fig8:" in text and "![fig8](panda/fig8.png)" in text
    assert "# TRIC experiments on the robot panda" in (panda / "REPORT.md").read_text()
    with pytest.raises(SystemExit):
        cli.main(arguments + ["--beside", str(tmp_path / "none")])
    assert "--beside takes results folders" in capsys.readouterr().err
    (paper / "fig9.json").write_text(_result("mixed", "panda"))
    assert cli.main(arguments) == 2
    assert "the results mix robots ['panda', 'tric_arm_hand']" in capsys.readouterr().err


def test_the_jolt_trace_tells_rest_the_jolt_and_rest_again():
    """exp5's trace text on a hand-made trace: at rest and gripped at 2 s, jolted at 3 s (f rises
    from 0.8 to 1.5 and falls back), at rest again at 4.5 s; the same with f dipping below 0.8 in
    the tick before it rises (a jolt throws the hand over a few ticks): f is back below 0.8 only
    after its peak; and on one that never rests again."""
    from tric_control.experiments.exp5 import trace_text

    t = np.round(np.arange(0.0, 6.0, 0.01), 2)
    phase = ["descending"] * 200 + ["gripping"] * 30 + ["at rest"] * 71
    phase += ["descending"] * 149 + ["gripping"] * 30 + ["at rest"] * 120
    f = np.where(t <= 3.0, 1.0 - 0.1 * t, 1.5 - 0.5 * (t - 3.0))
    f = np.where(np.array(phase) == "descending", f, np.nan)
    trace = {
        "t": t.tolist(),
        "f": f.tolist(),
        "phase": phase,
        "push_at_s": 3.0,
        "rested_at_s": 2.0,
        "situation": "s",
        "success": True,
        "outcome": "converged",
    }
    text = trace_text(trace)
    assert "it came to rest and gripped at 2.00 s" in text
    assert "jolted at 3.00 s, f rises from 0.8 to 1.5" in text
    assert "back below 0.8 1.40 s after the jolt" in text
    assert "it comes to rest and grips again at 4.50 s" in text
    dipping = f.copy()
    dipping[301] = 0.7  # t = 3.01 s, descending: below the 0.8 before the jolt, before the rise
    text = trace_text({**trace, "f": dipping.tolist()})
    assert "f rises from 0.8 to 1.5" in text and "back below 0.8 1.40 s after the jolt" in text
    never = {**trace, "phase": phase[:301] + ["descending"] * 299, "rested_at_s": None}
    assert "did not come to rest before the jolt" in trace_text(never)
    assert "does not come to rest again before its budget" in trace_text(never)


def test_tric_experiments_refuses_a_robot_it_cannot_load(tmp_path, capsys):
    assert cli.main(["table1", "--robot", "no_robot", "--out", str(tmp_path / "run")]) == 2
    assert "tric-experiments: no robot profile 'no_robot'" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()
