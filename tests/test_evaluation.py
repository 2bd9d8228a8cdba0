"""Evaluation: records and summaries on hand-made cases, tric-eval's refusals, and tric-eval through
the real nodes (the teacher's JSON records; serial and parallel runs giving the same records); the
experiment report and its discussions on hand-made results."""

import json
import math
import pathlib

import pytest

from conftest import record_fields
from tric_control import evaluate_cli
from tric_control.evaluation import graph as graph_evaluation
from tric_control.evaluation.records import EpisodeRecord, report, summarize, table, write_json
from tric_learning.training.value import TrainingConfig, train_from_bags
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation_files import save_situations

BAGS = pathlib.Path(__file__).resolve().parent.parent / "bags" / "sphere"


def grasp(name, cost, lift, distance=0.02, margin=0.1, outcome="converged", failure=""):
    return EpisodeRecord(
        situation=name,
        task="grasp",
        agent="tric",
        success=cost < 0.25 and lift,
        grasp_cost=cost,
        lift_passed=lift,
        lid_angle=math.nan,
        min_distance=distance,
        collided=distance < 0,
        min_joint_margin=margin,
        steps=500,
        wall_time_s=3.0,
        outcome=outcome,
        failure=failure,
    )


def test_summary_of_hand_made_records(tmp_path):
    failed = EpisodeRecord(
        situation="c",
        task="grasp",
        agent="tric",
        success=False,
        grasp_cost=math.nan,
        lift_passed=None,
        lid_angle=math.nan,
        min_distance=math.nan,
        collided=False,
        min_joint_margin=math.nan,
        steps=0,
        wall_time_s=0.1,
        outcome="failed",
        message="no joint states",
    )
    records = [
        grasp("a", 0.1, True),
        grasp("b", 0.3, False, distance=-0.004, margin=0.02, failure="collision"),
        failed,
        grasp("d", 0.5, False, failure="palm off target"),
        grasp("e", 0.6, False, failure="palm off target"),
    ]
    summary = summarize(records)
    assert summary["episodes"] == 5 and summary["failed_runs"] == 1 and summary["successes"] == 1
    assert summary["grasp_cost_mean"] == pytest.approx(0.375) and summary[
        "grasp_cost_max"
    ] == pytest.approx(0.6)
    assert (
        summary["good_grasps"] == 1 and summary["lift_passed"] == 1 and summary["collisions"] == 1
    )
    assert summary["failures"] == {"palm off target": 2, "collision": 1}  # most frequent first
    assert summary["min_distance"] == pytest.approx(-0.004) and summary[
        "min_joint_margin"
    ] == pytest.approx(0.02)
    assert math.isnan(summary["lid_angle_mean"]) and summary["boxes_opened"] == 0
    text = table(records, "title")
    assert "failed: no joint states" in text and "1/5 succeeded" in text and "1 collisions" in text
    assert "failures: palm off target 2, collision 1" in text
    lines = text.splitlines()
    assert (
        lines[1].endswith(" failure")
        and lines[4].endswith(" collision")
        and lines[3].endswith(" -")
    )
    data = json.loads(write_json(tmp_path / "out.json", report(records)).read_text())  # strict JSON
    assert data["summary"]["lid_angle_mean"] is None and data["episodes"][2]["grasp_cost"] is None
    assert (
        data["episodes"][1]["failure"] == "collision"
        and data["summary"]["failures"]["palm off target"] == 2
    )


def test_bad_arguments_are_refused(tmp_path, capsys):
    assert evaluate_cli.main(["--model", str(tmp_path / "missing.safetensors"), "sphere_test"]) == 2
    assert "does not exist" in capsys.readouterr().err
    mixed = tmp_path / "mixed.yaml"
    save_situations(mixed, situations.sphere_grid()[:1] + situations.dataset("box_test")[:1])
    assert evaluate_cli.main(["--teacher", "--situations-file", str(mixed)]) == 2
    assert "mix tasks" in capsys.readouterr().err
    with pytest.raises(SystemExit) as refused:
        evaluate_cli.main(["--teacher"])  # neither a data set nor a file
    assert (
        refused.value.code == 2
        and "give either DATASET or --situations-file" in capsys.readouterr().err
    )
    with pytest.raises(SystemExit) as refused:
        evaluate_cli.main(["--teacher", "sphere_test", "--jobs", "0"])
    assert refused.value.code == 2 and "--jobs must be in [1, 64]" in capsys.readouterr().err
    with pytest.raises(ValueError, match="jobs must be at least 1"):
        graph_evaluation.evaluate(situations.sphere_grid()[:1], None, jobs=0, progress=False)


def test_output_paths_and_impossible_situations_are_refused_before_the_first_episode(
    tmp_path, capsys
):
    (tmp_path / "plain").write_text("x")
    refusals = [
        (
            ["--teacher", "sphere_test", "--json", str(tmp_path)],
            f"--json file {tmp_path} is a folder",
        ),
        (
            ["--teacher", "sphere_test", "--json", "/proc/x.json"],
            "--json file /proc/x.json cannot be written",
        ),
        (
            ["--teacher", "sphere_test", "--snapshots", str(tmp_path / "plain")],
            f"--snapshots folder {tmp_path / 'plain'} cannot be used: {tmp_path / 'plain'} is a "
            "file",
        ),
        (["--model", str(tmp_path), "sphere_test"], f"model file {tmp_path} is a folder"),
        (
            ["--model", str(tmp_path / "plain"), "sphere_test", "--json", str(tmp_path / "plain")],
            f"--json file {tmp_path / 'plain'} is an input of this run",
        ),
        (
            ["--teacher", "sphere_test", "--json", str(tmp_path / "plain")],
            f"--json file {tmp_path / 'plain'} exists; give --overwrite to replace it",
        ),
        (
            ["--teacher", "sphere_test", "--json", "/dev/null", "--overwrite"],
            "--json file /dev/null exists and is not a regular file",
        ),
        (
            ["--teacher", "sphere_test", "--json", str(tmp_path / ("n" * 256 + ".json"))],
            "is longer than the 255 bytes the file system takes",
        ),
    ]
    inside = situations.sphere("inside_the_base", (0.0, 0.0, 0.05))
    save_situations(tmp_path / "impossible.yaml", [inside])
    refusals.append(
        (
            ["--teacher", "--situations-file", str(tmp_path / "impossible.yaml")],
            "situation 'inside_the_base': the object (sphere) intersects the robot's base_link",
        )
    )
    for arguments, reason in refusals:
        assert evaluate_cli.main(arguments) == 2
        error = capsys.readouterr().err
        assert error.startswith("tric-eval: ") and reason in error and error.count("\n") == 1, error
    assert sorted(p.name for p in tmp_path.iterdir()) == ["impossible.yaml", "plain"]


def test_tric_eval_writes_the_teacher_s_records_as_json(tmp_path):
    """tric-eval --teacher --situations-file --json through the nodes (TRIC's episodes through the
    nodes are tric-demo's, test_demo.py)."""
    chosen = situations.dataset("sphere_test")[3:4]
    path = tmp_path / "one.yaml"
    save_situations(path, chosen)
    assert (
        evaluate_cli.main(
            ["--teacher", "--situations-file", str(path), "--json", str(tmp_path / "t.json")]
        )
        == 0
    )
    teacher = json.loads((tmp_path / "t.json").read_text())
    assert teacher["agent"] == "teacher" and teacher["summary"]["episodes"] == 1
    [record] = teacher["episodes"]
    assert record["situation"] == chosen[0].name and record["outcome"] == "demonstrated"
    assert record["grasp_cost"] < 0.25 and record["lift_passed"] and not record["collided"]
    # docs/design.md 6: no measured joint more than 0.01 rad past a limit
    assert record["max_joint_overshoot"] <= 0.01


@pytest.mark.slow
def test_parallel_evaluation_gives_the_serial_records(tmp_path):
    """jobs = 2: two spawned workers, each with its graph on a domain of its own; the records come
    back in the situations' order, and equal to the serial run's in every field but the wall time
    (the lockstep episodes and the controller are deterministic bit for bit)."""
    chosen = situations.dataset("sphere_test")[5:8]
    # any model will do: both runs must agree
    quick = TrainingConfig(noisy_samples=5, max_iterations=20)
    model = train_from_bags(
        sorted(BAGS.glob("*.mcap"))[::9], tmp_path / "quick.safetensors", quick, RobotModel()
    ).path
    serial = graph_evaluation.evaluate(chosen, model, max_steps=150, progress=False)
    parallel = graph_evaluation.evaluate(chosen, model, max_steps=150, progress=False, jobs=2)
    assert [r.situation for r in parallel] == [s.name for s in chosen]
    assert all(r.agent == "tric" and r.outcome != "failed" for r in serial)
    assert [record_fields(r) for r in parallel] == [record_fields(r) for r in serial]
    # raised in a worker
    with pytest.raises(ValueError, match="missing.safetensors does not exist"):
        graph_evaluation.evaluate(
            chosen, tmp_path / "missing.safetensors", max_steps=150, progress=False, jobs=2
        )


def test_a_failed_experiment_leaves_the_others_run(tmp_path, capsys, monkeypatch):
    """tric-experiments goes on past an experiment that fails: the next one runs and is kept, the
    report is written, and the run exits 2 naming the failed one."""
    import argparse
    import types

    from tric_control.experiments import cli

    def failing(_runner):
        raise RuntimeError("its demonstrations could not be recorded")

    def passing(_runner):
        return {"table": "boxes 25", "paper": "24", "discussion": "All opened."}

    modules = {
        "table2": types.SimpleNamespace(TITLE="fails", run=failing),
        "table4": types.SimpleNamespace(TITLE="passes", run=passing),
    }
    monkeypatch.setattr(cli, "experiment", modules.__getitem__)
    args = argparse.Namespace(names=["table2", "table4"], situations=30, check=False, beside=[])
    runner = types.SimpleNamespace(profile=types.SimpleNamespace(name="panda"))
    assert cli._run_each(args, tmp_path, tmp_path / "results.md", runner) == 2
    kept = json.loads((tmp_path / "table4.json").read_text())
    assert kept["table"] == "boxes 25" and kept["robot"] == "panda"
    assert not (tmp_path / "table2.json").exists()
    assert "boxes 25" in (tmp_path / "REPORT.md").read_text()
    err = capsys.readouterr().err
    assert "table2: its demonstrations could not be recorded" in err
    assert "failed: table2" in err


def test_experiment_report_from_hand_made_results(tmp_path, capsys):
    from tric_control.experiments import cli, report

    (tmp_path / "table3.json").write_text(
        json.dumps(
            {
                "table": "agent  cost\nteacher 0.064",
                "paper": "teacher 0.07",
                "date": "2026-11-22 12:00",
                "wall_s": 12.0,
                "discussion": "Our teacher matches.",
            }
        )
    )
    (tmp_path / "analysis.json").write_text(
        json.dumps(
            {
                "table": "f decreases",
                "paper": "f decreases",
                "date": "2026-11-22 12:00",
                "wall_s": 5.0,
                "figures": ["analysis/a.png", "analysis/b.png"],
            }
        )
    )
    text = report.write_report(tmp_path).read_text()
    assert "## table3: Cylinders" in text and "teacher 0.064" in text
    assert "Paper: teacher 0.07.\n\nOur teacher matches.\n\n![table3](table3.png)" in text
    assert "![analysis](analysis/a.png)\n![analysis](analysis/b.png)" in text
    assert text.index("## table3") < text.index("## analysis")  # the order of EXPERIMENTS
    assert "## fig9" not in text  # not run: not reported
    with pytest.raises(SystemExit) as refused:
        cli.main(["table9", "--out", str(tmp_path)])
    assert refused.value.code == 2 and "unknown experiment(s) table9" in capsys.readouterr().err


def test_grasp_rows_evaluate_the_teacher_then_each_model_over_its_seeds():
    """experiments.rows.grasp_rows: the teacher first, then each model over the runner's seeds (a
    stand-in runner that records its calls); grasp_result tabulates and plots them."""
    from tric_control.experiments.rows import grasp_result, grasp_rows

    class Runner:
        def __init__(self):
            self.calls = []

        def evaluate(self, tests, model, desc):
            self.calls.append(("evaluate", model, desc))
            return [grasp("a", 0.02, True), grasp("b", 0.04, True)]

        def over_seeds(self, tests, label, **model):
            self.calls.append(("over_seeds", label, model))
            return {seed: [grasp("a", 0.05 * (seed + 1), seed < 2)] for seed in (0, 1, 2)}

    runner = Runner()
    models = {"TRIC K = 0": dict(name="c_k0", hidden_units=0), "TRIC K = 30": dict(name="c_k30")}
    rows = grasp_rows(runner, ["a", "b"], models)
    assert runner.calls == [
        ("evaluate", None, "teacher"),
        ("over_seeds", "TRIC K = 0", dict(name="c_k0", hidden_units=0)),
        ("over_seeds", "TRIC K = 30", dict(name="c_k30")),
    ]
    assert list(rows) == ["teacher", "TRIC K = 0", "TRIC K = 30"]
    assert rows["teacher"]["cost_mean"] == pytest.approx(0.03) and rows["teacher"]["good"] == 2
    assert rows["TRIC K = 30"]["lift"] == [1, 1, 0]
    assert rows["TRIC K = 30"]["cost_mean"] == pytest.approx(0.1)
    result = grasp_result(rows, "Table 3: cylinders", "paper numbers", "the discussion")
    assert result["rows"] is rows and result["paper"] == "paper numbers"
    assert result["discussion"] == "the discussion" and "TRIC K = 30" in result["table"]
    (axis,) = result["figure"].axes
    assert axis.get_title() == "Table 3: cylinders"
    assert [bar.get_height() for bar in axis.patches] == pytest.approx([0.03, 0.1, 0.1])


def grasp_row(mean, good=15, lift=15, collisions=0, std=0.01, episodes=15, at_rest=0):
    return {
        "cost_mean": mean,
        "cost_std": std,
        "cost_max": mean + 0.02,
        "good": good,
        "lift": lift,
        "collisions": collisions,
        "episodes": episodes,
        "at_rest": at_rest,
    }


def seeded(*rows):
    """A seeded grasp row (experiments.rows.seeded_grasp_row's shape), one grasp_row per seed."""
    means = [row["cost_mean"] for row in rows]
    return {
        "seeds": dict(enumerate(rows)),
        "cost_mean": sum(means) / len(means),
        "cost_min": min(means),
        "cost_max_seed": max(means),
        "good": [r["good"] for r in rows],
        "lift": [r["lift"] for r in rows],
        "collisions": [r["collisions"] for r in rows],
        "episodes": rows[0]["episodes"],
    }


def test_discussions_follow_the_numbers():
    from tric_control.experiments import fig8, table1, table3, table4

    close = table1.discussion(
        {
            "teacher": grasp_row(0.02),
            "TRIC K = 30": seeded(grasp_row(0.04), grasp_row(0.045), grasp_row(0.03)),
        }
    )
    assert (
        "0.040/0.045/0.030 (mean 0.038, min 0.030, max 0.045)" in close
        and "the gaps +0.020/+0.025/+0.010" in close
    )
    assert "Every group reproduces the paper's result" in close
    far = table1.discussion(
        {
            "teacher": grasp_row(0.02),
            "TRIC K = 30": seeded(
                grasp_row(0.04), grasp_row(0.3, good=9, lift=10), grasp_row(0.04, collisions=1)
            ),
        }
    )
    assert "We fall short of the paper with group 1, group 2." in far and "collisions 0/0/1" in far

    def fig8_rows(costs, few_good=15):
        """Rows of every Fig. 8 setting: costs[(N, M)] for the default variant, 0.1 more for the
        others."""
        rows = {}
        for k, variant in enumerate(fig8.FIG8_VARIANTS):
            for (demos, samples), cost in costs.items():
                good = few_good if (demos, k) == (3, 0) else 15
                rows[f"{variant} {demos} {samples}"] = dict(
                    grasp_row(cost + 0.1 * (k > 0), good=good),
                    variant=variant,
                    demos=demos,
                    samples=samples,
                )
        return rows

    like_paper = {(27, 5): 0.3, (27, 20): 0.05, (27, 60): 0.05, (3, 60): 0.06, (9, 60): 0.05}
    text = fig8.discussion(fig8_rows(like_paper), 27, 60)
    assert (
        text.count("as in the paper") == 3 and "consistent with the paper's saturation" in text
    ), text
    assert "L_n only and L_g only are clearly worse" in text
    unlike = {**like_paper, (3, 60): 0.6, (27, 20): 0.2}
    text = fig8.discussion(fig8_rows(unlike, few_good=4), 27, 60)
    assert (
        "a few demonstrations are not enough" in text and "N matters as much as M or more" in text
    )
    assert "still a clear gain" in text and "both terms together are best" in text
    assert "The means of N = 3, M = 60 (4/15 good) are pulled up by their failed grasps" in text

    def good_tric():
        return seeded(
            grasp_row(0.1, good=9, lift=8, episodes=10, at_rest=9),
            grasp_row(0.08, good=10, lift=9, episodes=10, at_rest=10),
            grasp_row(0.11, good=9, lift=9, episodes=10, at_rest=8),
        )

    cylinders = {
        "teacher": grasp_row(0.02, episodes=10),
        "TRIC K = 0": seeded(*(grasp_row(0.3, good=6, episodes=10) for _ in range(3))),
        "TRIC K = 30": good_tric(),
        table3.SECOND_DRAW: good_tric(),
        "TRIC K = 30" + table3.VALIDATION: good_tric(),
        table3.SECOND_DRAW + table3.VALIDATION: good_tric(),
    }
    text = table3.discussion(cylinders)
    assert (
        "Every group and draw meets the design's targets" in text
        and "K = 30 beats K = 0 with every group" in text
    )
    assert "Of TRIC K = 30's good test grasps, 96% came to rest" in text
    cylinders["TRIC K = 30"]["seeds"][1] = grasp_row(0.35, good=7, lift=4, episodes=10)
    cylinders[table3.SECOND_DRAW + table3.VALIDATION]["seeds"][2] = grasp_row(
        0.2, good=8, lift=8, episodes=10
    )
    text = table3.discussion(cylinders)
    assert (
        "TRIC K = 30: group 1; TRIC K = 30, 2nd draw (val): group 2." in text
        and "K = 30 beats K = 0 with groups 0, 2 only" in text
    )

    def boxes(tric, joint, finger):
        rows = {
            name: {"opened": opened, "episodes": 25}
            for name, opened in (
                ("TRIC", tric),
                ("DPL joint space", joint),
                ("DPL finger space", finger),
            )
        }
        rows["teacher"] = {"opened": [25], "episodes": 25}
        return rows

    text = table4.discussion(boxes([24, 23, 25], [2, 1, 3], [9, 8, 7]))
    assert "TRIC 24/23/25 (mean 24.0, min 23, max 25) (the paper 24)" in text
    assert (
        "TRIC opens at least 23 with every group" in text
        and "Both DPL variants open fewer boxes" in text
    )
    text = table4.discussion(boxes([24, 12, 25], [2, 13, 3], [9, 8, 7]))
    assert "TRIC misses the design's 23 with 1 of 3 seeds (at worst 12)" in text
    assert "A DPL variant opens as many as 13 with one seed" in text

    def seeded_boxes(opened, episodes, at_rest):
        return {
            "seeds": {
                s: {"opened": o, "at_rest": a} for s, (o, a) in enumerate(zip(opened, at_rest))
            },
            "opened": opened,
            "episodes": episodes,
        }

    rows = boxes([24, 23, 25], [2, 1, 3], [9, 8, 7])
    rows["TRIC"] = seeded_boxes([24, 23, 25], 25, [24, 20, 25])
    rows["TRIC (val)"] = seeded_boxes([23, 24, 23], 25, [23, 24, 23])
    rows["TRIC (train)"] = seeded_boxes([10, 9, 10], 10, [10, 9, 10])
    text = table4.discussion(rows)
    assert "On the validation boxes TRIC opens 23/24/23" in text
    assert "the design's targets hold there too" in text
    assert "Of TRIC's opened boxes, 98% came to rest" in text
    rows["TRIC (train)"] = seeded_boxes([10, 8, 10], 10, [0, 0, 0])
    assert "short of the design's 23 and 9" in table4.discussion(rows)


def test_analysis_discussion_judges_every_task_and_seed():
    from tric_control.experiments import model_analysis

    def numbers(cosine, falls):
        return {
            "cosine_weighted": cosine,
            "cosine_moving": cosine + 0.05,
            "cosine_slow": cosine + 0.1,
            "falls": falls,
            "cosine_moving_early": cosine,
            "cosine_moving_late": cosine + 0.1,
            "late_from_step": 30,
            "selected_features": 40,
            "features_95": 55,
            "kept_features": 130,
            "prop2": {"came_back": 0.5, "undershoot_median": 0.01},
            "top_gradients_changing_sign": 3,
            "top_features": [
                {"name": "d[object,fingertip_1]", "score": 1.0},
                {"name": "p[palm->object].x", "score": 0.5},
            ],
        }

    rows = {
        "sphere": {0: numbers(-0.95, 0.97), 1: numbers(-0.92, 0.96), 2: numbers(-0.7, 0.97)},
        "cylinder": {0: numbers(-0.6, 0.9), 1: numbers(-0.6, 0.9), 2: numbers(-0.6, 0.9)},
        "box": {0: numbers(-0.91, 1.0), 1: numbers(-0.91, 1.0), 2: numbers(-0.91, 1.0)},
    }
    text = model_analysis.discussion(rows)
    assert "sphere: mean cosine -0.950/-0.920/-0.700" in text and "2 of 3 seeds meet" in text
    assert "cylinder: mean cosine" in text and "0 of 3 seeds meet" in text and "box:" in text
    assert "over the slow steps (the lid lifting) -0.810/-0.810/-0.810" in text
    assert "50/50/50 (mean 50, min 50, max 50)% come back to rest nearer y_T" in text
    assert (
        "3 of 3 at most -0.8" in text and "carrying 95% of the score, all models: 55 to 55" in text
    )
    assert (
        "worse late, as in the paper" in text and "2 relate a hand landmark to the object" in text
    )
