"""tric-study resumes and never mixes stale results: an interrupted study run again does only its
missing cells and ends as an uninterrupted one; a cell that fails is named with its error, the rest
kept; cells that differ only in how they choose share their candidates; with --every-candidate
each candidate is measured and the selection's study printed."""

import json

import pytest

from conftest import REFERENCE_BAGS as BAGS
from conftest import study_results
from tric_control.study import candidates as study_candidates
from tric_control.study import cli as study
from tric_control.study import runs as study_runs

#: Control ticks per episode here: enough to move and to be judged, short enough for a test.
TICKS = 40
#: Two cells (seeds) of a short training on the spheres, measured on the 10 obstacle validation
#: situations with short episodes.
STUDY = [
    "--variant",
    f"tiny=candidates=1,max_iterations=3,noisy_samples=3,grasp_steps={TICKS}",
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
    """{"trained": [seeds], "rolled out": [seeds of kept models], "measured": [cell
    descriptions]}: the candidates trained, those rolled out again, and the sets measured, as they
    start."""
    runs = {"trained": [], "rolled out": [], "measured": []}
    train, evaluate = study_candidates.study_candidate, study_runs.evaluate_offline

    def counting_train(dataset, config, max_steps, options, rounds, kept, robot):
        runs["trained" if kept is None else "rolled out"].append(config.seed)
        return train(dataset, config, max_steps, options, rounds, kept, robot)

    def counting_evaluate(*args, desc, **kwargs):
        runs["measured"].append(desc)
        return evaluate(*args, desc=desc, **kwargs)

    monkeypatch.setattr(study_candidates, "study_candidate", counting_train)
    monkeypatch.setattr(study_runs, "evaluate_offline", counting_evaluate)
    monkeypatch.chdir(BAGS.parent)  # tric-study reads bags/ of the working directory
    return runs


def test_an_interrupted_study_does_only_its_missing_cells(tmp_path, monkeypatch, counted):
    whole, resumed = tmp_path / "whole", tmp_path / "resumed"
    assert study.main([*STUDY, "--out", str(whole)]) == 0
    assert counted == {
        "trained": [0, 1],
        "rolled out": [],
        "measured": ["tiny g0 obstacle_val", "tiny g1 obstacle_val"],
    }

    # the second cell is interrupted (Ctrl-C) as its episodes start: the first is kept
    evaluate = study_runs.evaluate_offline

    def interrupted(*args, desc, **kwargs):
        if desc.startswith("tiny g1"):
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
    assert counted == {"trained": [], "rolled out": [], "measured": ["tiny g1 obstacle_val"]}
    assert study_results(resumed) == study_results(whole)

    # the episodes' code changes: both candidates are rolled out again and both cells measured
    # again, their models re-used
    digest = study_runs.code_digest

    def changed(*modules):
        return "changed" if "tric_control.evaluation.offline" in modules else digest(*modules)

    monkeypatch.setattr(study_runs, "code_digest", changed)
    monkeypatch.setattr(study_candidates, "code_digest", changed)
    counted["measured"].clear()
    assert study.main([*STUDY, "--out", str(resumed)]) == 0
    assert counted == {
        "trained": [],
        "rolled out": [0, 1],
        "measured": ["tiny g0 obstacle_val", "tiny g1 obstacle_val"],
    }
    kept = [json.loads(p.read_text()) for p in (resumed / "candidates").glob("*.rollouts.json")]
    assert sorted(k["key"]["episode_code"] == "changed" for k in kept) == [False, False, True, True]


def test_a_failed_cell_is_named_with_its_error_and_the_rest_kept(
    tmp_path, monkeypatch, counted, capsys
):
    evaluate = study_runs.evaluate_offline

    def failing(*args, desc, **kwargs):
        if desc.startswith("tiny g0"):
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
    assert counted == {"trained": [], "rolled out": [], "measured": ["tiny g0 obstacle_val"]}
    results = json.loads((tmp_path / "study.json").read_text())
    assert sorted(results["rows"]) == ["tiny/obstacle/0", "tiny/obstacle/1"]
    assert results["failed"] == {}


def test_cells_that_choose_alike_share_their_candidates_and_every_one_is_measured(
    tmp_path, counted, capsys
):
    """Two variants of one training, one keeping the best of 2 candidates, the other both as an
    ensemble: 2 candidates are trained in all; with --every-candidate each is measured (once,
    though two cells hold it) and the selection's study printed."""
    tiny = "max_iterations=3,noisy_samples=3,grasp_steps=40"
    arguments = [
        "--variant",
        f"best=candidates=2,{tiny}",
        "--variant",
        f"pair=candidates=2,members=2,{tiny}",
        "--tasks",
        "obstacle",
        "--seeds",
        "0",
        "--jobs",
        "1",
        "--executor",
        "processes",
        "--every-candidate",
        "--out",
        str(tmp_path),
    ]
    assert study.main(arguments) == 0
    assert counted["trained"] == [0, 1] and counted["rolled out"] == []
    assert sorted(counted["measured"]) == [
        "best g0 obstacle_val",  # the chosen model: one of the two, so measured as a candidate
        "best g0 s1 obstacle_val",
        "pair g0 obstacle_val",  # the ensemble
    ] or sorted(counted["measured"]) == [
        "best g0 obstacle_val",
        "best g0 s0 obstacle_val",
        "pair g0 obstacle_val",
    ]
    rows = json.loads((tmp_path / "study.json").read_text())["rows"]
    best, pair = rows["best/obstacle/0"], rows["pair/obstacle/0"]
    assert len(best["selection"]["chosen"]) == 1 and sorted(pair["selection"]["chosen"]) == [0, 1]
    assert [c["seed"] for c in best["candidates"]] == [0, 1]
    assert best["candidates"] == pair["candidates"]
    assert set(best["candidates"][0]["scores"]) == {
        "landmarks",
        "features",
        "joints",
        "value",
        "judge",
        "successes",
    }
    printed = capsys.readouterr().out
    assert "best / obstacle: 2 candidates in 1 groups" in printed
    assert "Spearman against the validation result" in printed and "best of 2: blind" in printed
    assert "pooled: the expected result of the choice among 2 of all 2 candidates" in printed
    # the same two candidates, so the same choice: the variants differ by nothing
    assert (
        "obstacle: best minus pair, pooled, the default score's choice: +0 +- 0 (2 candidates"
        in (printed)
    )
