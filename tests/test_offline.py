"""tric-eval --offline: the controller core on the physics without nodes gives the episodes the
nodes give, the same records bit for bit but the wall time (the results' tables come from the nodes;
sweeps run offline)."""

import json
import time

import pytest

from conftest import REFERENCE_BAGS as BAGS
from conftest import record_fields
from tric_control import evaluate_cli
from tric_control.evaluation import graph as graph_evaluation
from tric_control.evaluation.offline import OfflineEvaluator, evaluate_offline
from tric_learning.training.value import TrainingConfig, train_from_bags
from tric_sim.ros.topic_poller import TopicPoller
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation_files import save_situations


@pytest.fixture(scope="module")
def models(tmp_path_factory, reference_sphere_training):
    box = train_from_bags(
        [BAGS / "box"],
        tmp_path_factory.mktemp("models") / "box.safetensors",
        TrainingConfig(),
        RobotModel(),
    )
    return {"grasp": reference_sphere_training.path, "open_box": box.path}


@pytest.mark.slow
def test_offline_and_node_episodes_agree_on_three_spheres_and_a_box(models):
    """The same records from both paths, in every field but the wall time: the lockstep simulator
    node steps the same physics as the offline path, and the controller is deterministic bit for
    bit."""
    spheres = situations.dataset("sphere_test")[:3]
    offline = evaluate_offline(spheres, str(models["grasp"]), progress=False)
    nodes = graph_evaluation.evaluate(spheres, models["grasp"], progress=False)
    assert [record_fields(r) for r in offline] == [record_fields(r) for r in nodes]
    # both paths name the failure class; a collision is one, even of a good grasp
    for record in offline:
        assert (record.failure == "") == (record.success and not record.collided)
    boxes = situations.dataset("box_train")[:1]
    [box_offline] = evaluate_offline(boxes, str(models["open_box"]), 1200, progress=False)
    [box_nodes] = graph_evaluation.evaluate(boxes, models["open_box"], 1200, progress=False)
    assert record_fields(box_offline) == record_fields(box_nodes)
    assert (box_offline.failure == "") == (box_offline.success and not box_offline.collided)
    # docs/design.md 6: no joint more than 0.01 rad past a limit
    assert box_offline.max_joint_overshoot <= 0.01


def test_both_paths_name_the_failure_of_an_episode_cut_short(tmp_path):
    """Five ticks leave the hand at home, far above the sphere with its fingers open: the hidden
    metrics' failure class reaches the records of both paths."""
    # any model will do: it has no time to move
    quick = TrainingConfig(noisy_samples=5, max_iterations=20)
    model = train_from_bags(
        sorted((BAGS / "sphere").glob("*.mcap"))[::9],
        tmp_path / "quick.safetensors",
        quick,
        RobotModel(),
    ).path
    sphere = situations.dataset("sphere_test")[:1]
    [offline] = evaluate_offline(sphere, str(model), max_steps=5, progress=False)
    [nodes] = graph_evaluation.evaluate(sphere, model, max_steps=5, progress=False)
    assert record_fields(offline) == record_fields(nodes)
    assert offline.failure == "palm off target" and not offline.success


def test_the_metrics_wait_for_the_simulator_to_apply_the_last_command(models, monkeypatch):
    """The controller's episode ends as it publishes its last command; the simulator applies it a
    moment later. The node path must judge the state after that period, as the offline path does:
    here the simulator takes every command 50 ms late (outside its lock, so the metrics service
    could run first), and the records must still agree."""
    original = TopicPoller.poll

    def late_for_the_simulator(self, timeout_s):
        received = original(self, timeout_s)
        if self._node.get_name() == "simulator_lockstep" and received["command"]:
            time.sleep(0.05)
        return received

    monkeypatch.setattr(TopicPoller, "poll", late_for_the_simulator)
    sphere = situations.dataset("sphere_test")[:1]
    [offline] = evaluate_offline(sphere, str(models["grasp"]), max_steps=5, progress=False)
    [nodes] = graph_evaluation.evaluate(sphere, models["grasp"], max_steps=5, progress=False)
    assert record_fields(offline) == record_fields(nodes)


def test_offline_cli_writes_the_same_table_and_json(tmp_path, capsys):
    chosen = tmp_path / "one.yaml"
    save_situations(chosen, situations.dataset("sphere_test")[:1])
    out = tmp_path / "teacher.json"
    assert (
        evaluate_cli.main(
            ["--teacher", "--situations-file", str(chosen), "--offline", "--json", str(out)]
        )
        == 0
    )
    printed = capsys.readouterr().out
    assert "(offline)" in printed and "sphere_test_00" in printed
    data = json.loads(out.read_text())
    assert data["summary"]["episodes"] == 1 and data["episodes"][0]["outcome"] == "demonstrated"
    assert (
        data["episodes"][0]["grasp_cost"] < 0.25 and data["summary"]["max_joint_overshoot"] <= 0.01
    )


def test_offline_evaluation_refuses_mixed_tasks_and_bad_jobs():
    mixed = situations.sphere_grid()[:1] + situations.dataset("box_test")[:1]
    with pytest.raises(ValueError, match="mix tasks"):
        evaluate_offline(mixed, None, progress=False)
    with pytest.raises(ValueError, match="jobs must be at least 1"):
        evaluate_offline(mixed[:1], None, jobs=0, progress=False)


def test_the_offline_evaluator_refuses_a_fall_pace_out_of_range(models):
    """A knee the controller node would refuse is refused offline too, naming it (a negative one
    was taken as no pace)."""
    for knee in (-0.1, 1.5):
        with pytest.raises(ValueError, match="knee must be in"):
            OfflineEvaluator(
                "grasp", str(models["grasp"]), controller_options={"fall_pace_knee": knee}
            )
