"""Evaluation workers that die (tric-eval --jobs): the episodes they take down run again, each
alone, and an episode whose worker dies again is a failed record that says so; the run keeps
every other record."""

import os
import pathlib

from tqdm import tqdm

from tric_control.evaluation.records import EpisodeRecord, unjudged_fields
from tric_control.evaluation.workers import run_in_workers
from tric_sim.world import situations


class DyingEvaluator:
    """Ends its worker process (as a segfault would) on situations named 'doomed', and on one
    named 'once' the first time it runs (marker: a file in folder)."""

    def __init__(self, folder):
        self.folder = pathlib.Path(folder)

    def run(self, situation, snapshot):
        marker = self.folder / f"{situation.name}.ran"
        if situation.name == "doomed" or (situation.name == "once" and not marker.exists()):
            marker.touch()
            os._exit(1)
        return EpisodeRecord(
            **unjudged_fields(situation, "stand-in"), wall_time_s=0.0, outcome="step_budget"
        )


def make_dying_evaluator(_worker, folder):
    return DyingEvaluator(folder)


def test_a_dying_worker_loses_only_its_own_episode(tmp_path):
    names = ["a", "once", "b", "doomed", "c"]
    tests = [situations.sphere(name, (0.55, 0.0, 0.05)) for name in names]
    pools = []

    def arguments():
        pools.append(1)
        return (str(tmp_path),)

    with tqdm(total=len(tests), disable=True) as bar:
        records = run_in_workers(tests, None, 2, bar, make_dying_evaluator, arguments, "fallback")
    assert [r.situation for r in records] == names
    assert [r.outcome for r in records] == ["step_budget"] * 3 + ["failed", "step_budget"]
    doomed = records[3]
    assert doomed.agent == "stand-in"  # the other records' agent
    assert doomed.message == "its evaluation worker process died, twice"
    assert len(pools) >= 3 and (tmp_path / "once.ran").exists()  # one pool, then one per episode
