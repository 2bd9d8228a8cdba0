"""The executors (tric_control.evaluation.executors): Ray's actors give the process pool's records
bit for bit, offline and through the nodes; tric-study on a 2-node Ray cluster on this machine gives
a local run's results, both nodes working. Ray runs with one CPU a node and an 80 MB object store,
and is always shut down."""

import json
import math
import os
import pathlib
import sys

import pytest
from tqdm import tqdm

from conftest import REFERENCE_BAGS as BAGS
from conftest import record_fields, study_results
from tric_control.evaluation import executors
from tric_control.evaluation import graph as graph_evaluation
from tric_control.evaluation.offline import evaluate_offline
from tric_control.evaluation.records import EpisodeRecord, unjudged_fields
from tric_control.study import cli as study
from tric_learning.training.value import TrainingConfig, train_from_bags
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

ray = pytest.importorskip("ray")

#: Ray's object store in these tests, bytes (Ray's least is 75 MB).
OBJECT_STORE_BYTES = 80 * 2**20
#: Control ticks per episode here: enough to move and to be judged, short enough for a test.
TICKS = 40


@pytest.fixture(scope="module")
def quick_model(tmp_path_factory):
    """A model trained for seconds on 3 sphere demonstrations: it moves, which is all these tests
    compare."""
    return train_from_bags(
        sorted((BAGS / "sphere").glob("*.mcap"))[::9],
        tmp_path_factory.mktemp("model") / "quick.safetensors",
        TrainingConfig(noisy_samples=5, max_iterations=20),
        RobotModel(),
    ).path


def test_ray_actors_give_the_process_pool_s_records_bit_for_bit(quick_model):
    """The same episodes, offline and through the nodes (each actor's graph on a DDS domain of its
    own), from Ray's actors as from the process pool and in this process: every field but the wall
    time equal."""
    spheres = situations.dataset("sphere_test")[:3]
    model = str(quick_model)
    here = evaluate_offline(spheres, model, TICKS, progress=False)
    pool = evaluate_offline(spheres, model, TICKS, progress=False, jobs=2)
    with executors.open_executor(executors.ExecutorChoice("ray"), num_cpus=2) as ray_executor:
        offline = evaluate_offline(
            spheres, model, TICKS, progress=False, jobs=2, executor=ray_executor
        )
        nodes = graph_evaluation.evaluate(
            spheres[:2], model, TICKS, progress=False, jobs=2, executor=ray_executor
        )
        assert sum(ray_executor.node_work.values()) == len(spheres) + 2
        # a task between evaluations finds its CPU (the idle actors hold none)
        assert list(ray_executor.run_calls(pow, [(2, 5)], 1)) == [(0, 32)]
    expected = [record_fields(r) for r in here]
    assert [record_fields(r) for r in pool] == expected
    assert [record_fields(r) for r in offline] == expected
    assert [record_fields(r) for r in nodes] == expected[:2]
    assert all(r.steps == TICKS for r in here)
    assert not ray.is_initialized()


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

    def close(self):
        pass


def make_dying_evaluator(_worker, folder):
    return DyingEvaluator(folder)


def test_a_dying_ray_actor_loses_only_its_own_episode(tmp_path):
    """As a dying worker process of the pool (test_evaluation_workers): the episode of an actor
    that dies is tried again on a fresh actor, and one whose actor dies again is a failed record
    that says so; every other record is kept."""
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # tests/ is not on Ray's path
    names = ["a", "once", "b", "doomed", "c"]
    tests = [situations.sphere(name, (0.55, 0.0, 0.05)) for name in names]
    with executors.open_executor(executors.ExecutorChoice("ray"), num_cpus=2) as ray_executor:
        with tqdm(total=len(tests), disable=True) as bar:
            records = ray_executor.run_episodes(
                tests, None, 2, bar, make_dying_evaluator, lambda: (str(tmp_path),), "fallback"
            )
    assert [r.situation for r in records] == names
    assert [r.outcome for r in records] == ["step_budget"] * 3 + ["failed", "step_budget"]
    assert records[3].agent == "stand-in"  # the other records' agent
    assert records[3].message == "its evaluation worker process died, twice"
    assert (tmp_path / "once.ran").exists()


class ClosingEvaluator:
    """Marks its close with a file in folder, named for its worker."""

    def __init__(self, worker, folder):
        self.marker = pathlib.Path(folder) / f"closed_{worker}"

    def run(self, situation, snapshot):
        return EpisodeRecord(
            **unjudged_fields(situation, "stand-in"), wall_time_s=0.0, outcome="step_budget"
        )

    def close(self):
        self.marker.touch()


def test_ray_actors_close_their_evaluators_when_the_call_ends(tmp_path):
    """Each actor's evaluator (in the tools, a graph on a DDS domain) is closed when its
    run_episodes call returns, while the actors and Ray live on."""
    ray.cloudpickle.register_pickle_by_value(sys.modules[__name__])  # tests/ is not on Ray's path
    tests = [situations.sphere(name, (0.55, 0.0, 0.05)) for name in "abcd"]
    with executors.open_executor(executors.ExecutorChoice("ray"), num_cpus=2) as ray_executor:
        with tqdm(total=len(tests), disable=True) as bar:
            records = ray_executor.run_episodes(
                tests, None, 2, bar, ClosingEvaluator, lambda: (str(tmp_path),), "stand-in"
            )
        assert [r.outcome for r in records] == ["step_budget"] * 4
        assert sorted(p.name for p in tmp_path.iterdir()) == ["closed_0", "closed_1"]
        assert ray.is_initialized()


def test_an_address_means_ray_and_processes_refuse_one(monkeypatch):
    monkeypatch.delenv("RAY_ADDRESS", raising=False)

    def choice(executor=None, address=None):
        class Arguments:
            pass

        args = Arguments()
        args.executor, args.address, args.default_executor = executor, address, "processes"
        return executors.chosen_executor(args)

    assert choice() == executors.ExecutorChoice("processes")
    assert choice("ray") == executors.ExecutorChoice("ray", None)
    assert choice(address="head:6379") == executors.ExecutorChoice("ray", "head:6379")
    monkeypatch.setenv("RAY_ADDRESS", "head:6379")
    assert choice().remote and choice("processes") == executors.ExecutorChoice("processes")
    with pytest.raises(ValueError, match="--address runs on a Ray cluster"):
        choice("processes", "head:6379")


#: A study small enough for a test: two cells (seeds) of a short training, measured on the 15
#: validation spheres with short episodes.
TINY_STUDY = [
    "--variant",
    f"tiny=candidates=1,max_iterations=5,noisy_samples=5,grasp_steps={TICKS}",
    "--tasks",
    "sphere",
    "--seeds",
    "0",
    "1",
]


@pytest.mark.slow
def test_a_study_on_a_two_node_ray_cluster_gives_the_local_results(tmp_path, monkeypatch):
    """tric-study --address on a 2-node cluster (one CPU each, on this machine): the candidates
    and the episodes run on both nodes, the code reaches them through Ray's runtime environment
    and the demonstrations through its object store, the models and rows come back to --out, and
    they equal a run here."""
    from ray.cluster_utils import Cluster

    monkeypatch.chdir(BAGS.parent)  # tric-study reads bags/ of the working directory
    monkeypatch.delenv("RAY_ADDRESS", raising=False)
    local = tmp_path / "local"
    arguments = [*TINY_STUDY, "--out", str(local), "--jobs", "1", "--executor", "processes"]
    assert study.main(arguments) == 0

    opened = []

    def open_and_keep(*args, **kwargs):
        opened.append(executors.open_executor(*args, **kwargs))
        return opened[-1]

    monkeypatch.setattr(study, "open_executor", open_and_keep)
    node = {"num_cpus": 1, "object_store_memory": OBJECT_STORE_BYTES}
    cluster = Cluster(initialize_head=True, head_node_args={**node, "include_dashboard": False})
    try:
        cluster.add_node(**node)
        cluster.wait_for_nodes()
        remote = tmp_path / "remote"
        arguments = [*TINY_STUDY, "--out", str(remote), "--jobs", "2"]
        assert study.main([*arguments, "--address", cluster.address]) == 0
        nodes = {node.node_id for node in cluster.list_all_nodes()}
    finally:
        ray.shutdown()
        cluster.shutdown()
    [executor] = opened
    assert executor.kind == "ray"
    assert set(executor.node_work) == nodes and len(nodes) == 2  # both nodes worked
    # 2 candidates (each trained and rolled out in one call) and 2 x 15 episodes
    assert sum(executor.node_work.values()) == 2 + 2 * 15
    assert study_results(remote) == study_results(local)
    rows = json.loads((remote / "study.json").read_text())["rows"]
    assert sorted(rows) == ["tiny/sphere/0", "tiny/sphere/1"]
    assert all(math.isfinite(row["sets"]["sphere_val"]["cost_mean"]) for row in rows.values())
