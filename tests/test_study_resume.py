"""tric-study resumes and never mixes stale results: an interrupted study run again does only its
missing cells and ends as an uninterrupted one; a cell whose key changed (here the episodes' code)
is measured again, its model re-used; a cell that fails is named with its error, the rest kept."""

import json

import pytest

from conftest import REFERENCE_BAGS as BAGS
from conftest import study_results
from tric_control.study import cli as study
from tric_control.study import runs as study_runs

#: Control ticks per episode here: enough to move and to be judged, short enough for a test.
TICKS = 40
#: Two cells (seeds) of a short training on the spheres, measured on the 10 obstacle validation
#: situations with short episodes.
STUDY = [
    "--variant",
    f"tiny=max_iterations=3,noisy_samples=3,grasp_steps={TICKS}",
    "--tasks",
    "obstacle",
    "--seeds",
    "0",
    "1",
    "--jobs",
    "1",
    "--executor",
    "processes",
]


@pytest.fixture
def counted(monkeypatch):
    """{"trained": [seeds], "measured": [cell descriptions]}: the trainings and the sets measured,
    as they start."""
    runs = {"trained": [], "measured": []}
    train, evaluate = study_runs.train_study_model, study_runs.evaluate_offline

    def counting_train(config, bags):
        runs["trained"].append(config["seed"])
        return train(config, bags)

    def counting_evaluate(*args, desc, **kwargs):
        runs["measured"].append(desc)
        return evaluate(*args, desc=desc, **kwargs)

    monkeypatch.setattr(study_runs, "train_study_model", counting_train)
    monkeypatch.setattr(study_runs, "evaluate_offline", counting_evaluate)
    monkeypatch.chdir(BAGS.parent)  # tric-study reads bags/ of the working directory
    return runs


def test_an_interrupted_study_does_only_its_missing_cells(tmp_path, monkeypatch, counted):
    whole, resumed = tmp_path / "whole", tmp_path / "resumed"
    assert study.main([*STUDY, "--out", str(whole)]) == 0
    assert counted == {
        "trained": [0, 1],
        "measured": ["tiny s0 obstacle_val", "tiny s1 obstacle_val"],
    }

    # the second cell is interrupted (Ctrl-C) as its episodes start: the first is kept
    evaluate = study_runs.evaluate_offline

    def interrupted(*args, desc, **kwargs):
        if desc.startswith("tiny s1"):
            raise KeyboardInterrupt
        return evaluate(*args, desc=desc, **kwargs)

    monkeypatch.setattr(study_runs, "evaluate_offline", interrupted)
    counted["trained"].clear()
    assert study.main([*STUDY, "--out", str(resumed)]) == 130
    assert sorted(json.loads((resumed / "study.json").read_text())["rows"]) == ["tiny/obstacle/0"]
    assert counted["trained"] == [0, 1]  # both models were trained and kept

    monkeypatch.setattr(study_runs, "evaluate_offline", evaluate)
    counted["trained"].clear()
    counted["measured"].clear()
    assert study.main([*STUDY, "--out", str(resumed)]) == 0
    assert counted == {"trained": [], "measured": ["tiny s1 obstacle_val"]}
    assert study_results(resumed) == study_results(whole)

    # the episodes' code changes: both cells are measured again, their models re-used
    digest = study_runs.code_digest

    def changed(*modules):
        return "changed" if "tric_control.evaluation.offline" in modules else digest(*modules)

    monkeypatch.setattr(study_runs, "code_digest", changed)
    counted["measured"].clear()
    assert study.main([*STUDY, "--out", str(resumed)]) == 0
    assert counted == {"trained": [], "measured": ["tiny s0 obstacle_val", "tiny s1 obstacle_val"]}
    rows = json.loads((resumed / "study.json").read_text())["rows"]
    assert {row["key"]["episode_code"] for row in rows.values()} == {"changed"}


def test_a_failed_cell_is_named_with_its_error_and_the_rest_kept(
    tmp_path, monkeypatch, counted, capsys
):
    evaluate = study_runs.evaluate_offline

    def failing(*args, desc, **kwargs):
        if desc.startswith("tiny s0"):
            raise RuntimeError("the physics fell over")
        return evaluate(*args, desc=desc, **kwargs)

    monkeypatch.setattr(study_runs, "evaluate_offline", failing)
    assert study.main([*STUDY, "--out", str(tmp_path)]) == 1
    out = capsys.readouterr().out
    assert "1 of 2 cells failed (the others are kept):\n" in out
    assert "  tiny/obstacle/0: RuntimeError: the physics fell over\n" in out
    results = json.loads((tmp_path / "study.json").read_text())
    assert sorted(results["rows"]) == ["tiny/obstacle/1"]
    assert results["failed"] == {"tiny/obstacle/0": "RuntimeError: the physics fell over"}

    # run again, it measures the failed cell only, and no longer lists it as failed
    monkeypatch.setattr(study_runs, "evaluate_offline", evaluate)
    counted["trained"].clear()
    counted["measured"].clear()
    assert study.main([*STUDY, "--out", str(tmp_path)]) == 0
    assert counted == {"trained": [], "measured": ["tiny s0 obstacle_val"]}
    results = json.loads((tmp_path / "study.json").read_text())
    assert sorted(results["rows"]) == ["tiny/obstacle/0", "tiny/obstacle/1"]
    assert results["failed"] == {}
