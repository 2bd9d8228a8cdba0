"""Evaluation: records and summaries on hand-made cases, and tric-eval through the real nodes (the
teacher, and TRIC trained on the reference sphere bags grasping a sphere it never saw)."""

import json
import math
import pathlib

import pytest

from tric_control import evaluate_cli
from tric_control.evaluation import EpisodeRecord, report, summarize, table, write_json
from tric_learning.training import TrainingConfig, train_from_bags
from tric_sim import situations
from tric_sim.robot_model import RobotModel

BAGS = pathlib.Path(__file__).resolve().parent.parent / "bags" / "sphere"


def grasp(name, cost, lift, distance=0.02, margin=0.1, outcome="converged"):
    return EpisodeRecord(situation=name, task="grasp", agent="tric", success=cost < 0.25 and lift,
                         grasp_cost=cost, lift_passed=lift, lid_angle=math.nan, min_distance=distance,
                         collided=distance < 0, min_joint_margin=margin, steps=500, wall_time_s=3.0,
                         outcome=outcome)


def test_summary_of_hand_made_records(tmp_path):
    failed = EpisodeRecord(situation="c", task="grasp", agent="tric", success=False, grasp_cost=math.nan,
                           lift_passed=None, lid_angle=math.nan, min_distance=math.nan, collided=False,
                           min_joint_margin=math.nan, steps=0, wall_time_s=0.1, outcome="failed",
                           message="no joint states")
    records = [grasp("a", 0.1, True), grasp("b", 0.3, False, distance=-0.004, margin=0.02), failed]
    summary = summarize(records)
    assert summary["episodes"] == 3 and summary["failed_runs"] == 1 and summary["successes"] == 1
    assert summary["grasp_cost_mean"] == pytest.approx(0.2) and summary["grasp_cost_max"] == pytest.approx(0.3)
    assert summary["good_grasps"] == 1 and summary["lift_passed"] == 1 and summary["collisions"] == 1
    assert summary["min_distance"] == pytest.approx(-0.004) and summary["min_joint_margin"] == pytest.approx(0.02)
    assert math.isnan(summary["lid_angle_mean"]) and summary["boxes_opened"] == 0
    text = table(records, "title")
    assert "failed: no joint states" in text and "1/3 succeeded" in text and "1 collisions" in text
    data = json.loads(write_json(tmp_path / "out.json", report(records)).read_text())  # strict JSON
    assert data["summary"]["lid_angle_mean"] is None and data["episodes"][2]["grasp_cost"] is None


def test_bad_arguments_are_refused(tmp_path, capsys):
    assert evaluate_cli.main(["--model", str(tmp_path / "missing.safetensors"), "sphere_test"]) == 2
    assert "does not exist" in capsys.readouterr().err
    mixed = tmp_path / "mixed.yaml"
    situations.save_situations(mixed, situations.sphere_grid()[:1] + situations.dataset("box_test")[:1])
    assert evaluate_cli.main(["--teacher", "--situations-file", str(mixed)]) == 2
    assert "mix tasks" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        evaluate_cli.main(["--teacher"])  # neither a data set nor a file


@pytest.mark.slow
def test_teacher_and_tric_grasp_an_unseen_sphere_through_the_nodes(tmp_path):
    chosen = situations.dataset("sphere_test")[3:4]
    path = tmp_path / "one.yaml"
    situations.save_situations(path, chosen)
    assert evaluate_cli.main(["--teacher", "--situations-file", str(path), "--json", str(tmp_path / "t.json")]) == 0
    teacher = json.loads((tmp_path / "t.json").read_text())
    assert teacher["agent"] == "teacher" and teacher["summary"]["good_grasps"] == 1

    trained = train_from_bags([BAGS], tmp_path / "tric.safetensors", TrainingConfig(), RobotModel())
    [record] = evaluate_cli.evaluate(chosen, trained.path, snapshots=tmp_path / "snapshots", progress=False)
    assert record.agent == "tric" and record.outcome in ("converged", "step_budget")
    assert record.grasp_cost < 0.25 and record.lift_passed and not record.collided
    assert record.min_joint_margin > -0.05  # fingers squeezed by the contact may give a little
    assert (tmp_path / "snapshots" / f"{chosen[0].name}.png").is_file()


def test_experiment_report_from_hand_made_results(tmp_path, capsys):
    from tric_control import experiments

    (tmp_path / "table3.json").write_text(json.dumps({
        "table": "agent  cost\nteacher 0.064", "paper": "teacher 0.07", "date": "2026-11-22 12:00", "wall_s": 12.0}))
    text = experiments.write_report(tmp_path).read_text()
    assert "## table3: Cylinders" in text and "teacher 0.064" in text and "Paper: teacher 0.07." in text
    assert "## fig9" not in text  # not run: not reported
    with pytest.raises(SystemExit):
        experiments.main(["table9", "--out", str(tmp_path)])
    assert "unknown experiment(s) table9" in capsys.readouterr().err
