"""The trainer node in-process (~/train round trip, ~/progress, the busy answer, refused requests)
and the tric-train and tric-analyze commands, on three recorded sphere demonstrations."""

import contextlib
import io
import math
import shutil
import threading

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy

from conftest import HANG_S, call, wait_for, wait_future
from tric_control import train_cli, trainer_node
from tric_control.selection.settings import SelectionConfig
from tric_control.trainer_node import TrainerNode, selection_config, training_config
from tric_learning import analysis, analyze_cli
from tric_learning.demonstrations import demonstrate_all
from tric_learning.features import FeatureDefinition
from tric_learning.model_file import ModelFile, value_function
from tric_learning.training.value import TrainingConfig
from tric_msgs.msg import TrainingProgress
from tric_msgs.srv import Train
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

#: A training of a few seconds: not a useful model, but every stage of a real one, with two
#: candidates to choose from.
TINY = {"hidden_units": 5, "noisy_samples": 10, "max_iterations": 20}
CANDIDATES = 2
KEEP_ALL = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


@pytest.fixture(scope="module")
def bag_dir(tmp_path_factory):
    """Three sphere demonstrations recorded through the simulator, teacher and recorder nodes."""
    out = tmp_path_factory.mktemp("bags")
    rows = demonstrate_all(situations.sphere_grid()[12:15], out, 0.125, 0.0, progress=False)
    assert all(result.success and path for _, result, path in rows)
    return out


@pytest.fixture(scope="module")
def cli_run(bag_dir, tmp_path_factory):
    """tric-train on the bags: (exit status, what it printed, the model path)."""
    model = tmp_path_factory.mktemp("cli") / "tiny.safetensors"
    printed = io.StringIO()
    with contextlib.redirect_stdout(printed):
        status = train_cli.main(
            [
                str(bag_dir),
                "--out",
                str(model),
                "--hidden-units",
                "5",
                "--noisy-samples",
                "10",
                "--iterations",
                "20",
                "--seed",
                "3",
                "--candidates",
                str(CANDIDATES),
                "--executor",
                "processes",
                "--jobs",
                "2",
                "--quiet",
            ]
        )
    return status, printed.getvalue(), model


def train_request(bags, output, **overrides) -> Train.Request:
    return Train.Request(
        bag_paths=[str(path) for path in bags],
        output_path=str(output),
        **{**TINY, "candidates": CANDIDATES, **overrides},
    )


def trainer(context) -> TrainerNode:
    """A trainer node whose candidates train on spawned processes here (Ray is tested in
    tests/test_executors.py)."""
    return TrainerNode(
        context=context,
        parameter_overrides=[Parameter("executor", value="processes"), Parameter("jobs", value=2)],
    )


class ProgressListener(Node):
    """Keeps every message of /trainer/progress."""

    def __init__(self, context):
        super().__init__("test_progress_listener", context=context)
        self.messages = []
        self.create_subscription(
            TrainingProgress, "/trainer/progress", self.messages.append, KEEP_ALL
        )


def test_request_defaults_are_the_training_defaults():
    assert training_config(Train.Request()) == TrainingConfig()
    assert training_config(Train.Request(hidden_units=0)).hidden_units == 0
    assert selection_config(Train.Request()) == SelectionConfig()
    assert selection_config(Train.Request(candidates=3, members=2)) == SelectionConfig(3, 2)


class HeldJob:
    """Stands in for trainer_node.select_from_bags: a training that starts only when the test
    releases it (`release`), after saying it has begun (`entered`); then the real job runs. It holds
    the node's training slot for as long as the test needs, so a second request meets a running
    training."""

    def __init__(self, job):
        self.job, self.entered, self.release = job, threading.Event(), threading.Event()

    def __call__(self, *args, **kwargs):
        self.entered.set()
        assert self.release.wait(HANG_S), "the test never released the training"
        return self.job(*args, **kwargs)


def test_train_round_trip_with_progress_and_a_busy_answer(
    ros_context, spin, bag_dir, tmp_path, monkeypatch
):
    held = HeldJob(trainer_node.select_from_bags)
    monkeypatch.setattr(trainer_node, "select_from_bags", held)
    listener = spin(trainer(ros_context), ProgressListener(ros_context))[1]
    client = listener.create_client(Train, "/trainer/train")
    assert client.wait_for_service(timeout_sec=HANG_S)
    out = tmp_path / "models" / "tiny.safetensors"
    first = client.call_async(train_request([bag_dir], out))
    assert held.entered.wait(HANG_S), "the first training never started"
    busy = call(
        listener, Train, "/trainer/train", train_request([bag_dir], tmp_path / "second.safetensors")
    )
    assert not busy.success and busy.message.startswith("busy"), busy.message
    held.release.set()
    response = wait_future(first, what="the training's answer")
    assert response.success, response.message
    assert not (tmp_path / "second.safetensors").exists()

    assert response.model_path == str(out) and str(out) in response.message
    loaded = ModelFile.load(out, expected=FeatureDefinition.for_task("grasp", RobotModel()))
    model = value_function(loaded)
    assert response.input_features == len(model.scaling.kept) == len(loaded.info["kept_features"])
    assert 0 < response.selected_features <= response.input_features
    assert loaded.info["hyperparameters"] == TrainingConfig(**TINY).to_dict()
    assert loaded.info["losses"] == {
        "n": response.loss_n,
        "g": response.loss_g,
        "w": response.loss_w,
        "total": response.loss_total,
    }
    config = TrainingConfig(**TINY)
    assert response.loss_total == pytest.approx(
        config.alpha_n * response.loss_n
        + config.alpha_g * response.loss_g
        + config.alpha_w * response.loss_w
    )
    assert -1.0 <= response.loss_g < 0 < response.loss_n and response.loss_w > 0
    assert 0 < response.sampling_time_s and 0 < response.optimization_time_s
    assert response.train_time_s > response.sampling_time_s + response.optimization_time_s
    # every candidate, best first, and the one kept
    selection = loaded.info["selection"]
    assert sorted(response.candidate_seeds) == [0, 1] and len(response.candidate_scores) == 2
    assert list(response.chosen_seeds) == [response.candidate_seeds[0]] == selection["chosen"]
    assert list(response.candidate_scores) == sorted(response.candidate_scores)
    assert f"chose seed {response.chosen_seeds[0]} of 2 candidates" in response.message

    wait_for(lambda: listener.messages[-1].stage == "done", what="the 'done' progress message")
    stages = [m.stage for m in listener.messages]
    assert [s for k, s in enumerate(stages) if k == 0 or s != stages[k - 1]] == [
        "loading",
        "candidates",
        "saving",
        "done",
    ]
    fractions = [m.fraction for m in listener.messages]
    assert fractions == sorted(fractions) and fractions[-1] == 1.0
    candidates = [m for m in listener.messages if m.stage == "candidates"]
    assert [m.iteration for m in candidates] == [0, 1, 2]
    assert all(m.max_iterations == CANDIDATES for m in candidates)
    assert all(
        np.isfinite([m.loss_total, m.loss_n, m.loss_g, m.loss_w]).all() for m in candidates[1:]
    )
    assert math.isnan(listener.messages[0].loss_total)
    assert listener.messages[-1].loss_total == response.loss_total


def test_bad_requests_are_refused_and_write_nothing(ros_context, spin, bag_dir, tmp_path):
    listener = spin(trainer(ros_context), ProgressListener(ros_context))[1]
    inputs = tmp_path / "inputs"
    (inputs / "empty").mkdir(parents=True)
    (inputs / "empty.safetensors").mkdir()
    foreign = inputs / "notes.mcap"
    foreign.write_text("not a bag")
    good = sorted(bag_dir.glob("*.mcap"))[0]
    truncated = inputs / "truncated.mcap"
    truncated.write_bytes(good.read_bytes()[: good.stat().st_size // 2])
    out = tmp_path / "model.safetensors"
    refusals = [
        (
            train_request([inputs / "missing.mcap"], out),
            f"{inputs / 'missing.mcap'} does not exist",
        ),
        (train_request([inputs / "empty"], out), "holds no .mcap bags"),
        (train_request([], out), "no bags given"),
        (train_request([good, foreign], out), "notes.mcap"),
        (train_request([good, truncated], out), "truncated.mcap"),
        (train_request([bag_dir], out, sigma=0.0), "sigma must be in (0, 1] rad"),
        (train_request([bag_dir], out, noisy_samples=0), "noisy_samples must be in [1, 10000]"),
        (train_request([bag_dir], out, hidden_units=-2), "hidden_units must be in [0, 1000]"),
        (
            train_request([bag_dir], out, alpha_w=math.nan),
            "alpha_n, alpha_g and alpha_w must be finite and >= 0",
        ),
        (train_request([bag_dir], out, max_iterations=0), "max_iterations must be in [1, 100000]"),
        (train_request([bag_dir], out, members=0), "members must be in [1, candidates (2)]"),
        (train_request([bag_dir], out, candidates=0), "candidates must be in [1, 64]"),
        (
            train_request([bag_dir], out, selection_score="luck"),
            "the selection score must be one of landmarks",
        ),
        (
            train_request([bag_dir], out, correlation_threshold=1.5),
            "correlation_threshold must be in (0, 1]",
        ),
        (
            train_request([bag_dir], out, model_kind="dpl_finger"),
            "dpl_finger needs the 'box' landmark",
        ),
        (
            train_request([bag_dir], out, model_kind="dpl_joint", hidden_units=0),
            "hidden_units must be in [1, 1000]",
        ),
        (train_request([bag_dir], out, model_kind="svm"), "unknown model_kind 'svm'"),
        (train_request([bag_dir], tmp_path / "model.txt"), "must end in .safetensors"),
        (train_request([bag_dir], inputs), "must end in .safetensors"),
        (
            train_request([bag_dir], "/proc/x.safetensors"),
            "cannot be written: /proc refuses new files",
        ),
        (train_request([bag_dir], inputs / "empty.safetensors"), "is a folder"),
    ]
    for request, reason in refusals:
        response = call(listener, Train, "/trainer/train", request)
        assert not response.success and reason in response.message, (reason, response.message)
        assert response.model_path == ""
    assert sorted(p.name for p in tmp_path.rglob("*") if p.is_file()) == [
        "notes.mcap",
        "truncated.mcap",
    ]
    failed = lambda: [m for m in listener.messages if m.stage == "failed"]  # noqa: E731
    wait_for(lambda: len(failed()) == len(refusals), what="a 'failed' message per refusal")
    assert [m.message for m in failed()][-1].endswith("is a folder; give a file path")
    # bad bags are found while loading
    assert {m.stage for m in listener.messages} == {"loading", "failed"}


def test_a_client_that_goes_away_leaves_the_service_usable(ros_context, spin, bag_dir, tmp_path):
    listener = spin(trainer(ros_context), ProgressListener(ros_context))[1]
    leaving = Node("test_leaving_client", context=ros_context)
    client = leaving.create_client(Train, "/trainer/train")
    assert client.wait_for_service(timeout_sec=HANG_S)
    pending = client.call_async(train_request([bag_dir], tmp_path / "abandoned.safetensors"))
    wait_for(lambda: listener.messages, what="the first progress message")
    client.remove_pending_request(pending)  # the caller gives up on its answer ...
    leaving.destroy_node()  # ... and goes away while the training runs
    wait_for(
        lambda: listener.messages[-1].stage in ("done", "failed"),
        what="the abandoned training's end",
    )

    folder = tmp_path / "bags"
    shutil.copytree(bag_dir, folder)
    first = sorted(folder.glob("*.mcap"))[0]
    part = folder / "killed.mcap.part"
    part.write_bytes(first.read_bytes()[: first.stat().st_size // 2])
    response = call(
        listener, Train, "/trainer/train", train_request([folder], tmp_path / "next.safetensors")
    )
    assert response.success, response.message
    assert f"skipped {part}: an unfinished recording" in response.message
    # the abandoned training finished its work
    assert (tmp_path / "abandoned.safetensors").is_file()


def test_dpl_kinds_are_routed_to_dpl_training(ros_context, spin, bag_dir, tmp_path):
    listener = spin(trainer(ros_context), ProgressListener(ros_context))[1]
    out = tmp_path / "dpl.safetensors"
    request = Train.Request(
        bag_paths=[str(bag_dir)], output_path=str(out), model_kind="dpl_joint", max_iterations=20
    )
    response = call(listener, Train, "/trainer/train", request)
    assert response.success, response.message
    assert (
        response.message.startswith("dpl_joint trained on 3 demonstrations")
        and "training MSE" in response.message
    )
    loaded = ModelFile.load(out)
    assert loaded.kind == "dpl_joint" and loaded.info["hyperparameters"]["hidden_units"] == 60
    assert response.loss_total == loaded.info["losses"]["total"] and math.isnan(response.loss_n)
    assert response.input_features == len(loaded.arrays["kept"]) > 0
    wait_for(
        lambda: listener.messages and listener.messages[-1].stage == "done",
        what="the 'done' message",
    )
    assert {m.stage for m in listener.messages} == {"loading", "optimizing", "saving", "done"}


def test_tric_train_writes_a_loadable_model(cli_run):
    status, printed, model = cli_run
    assert status == 0
    for expected in (
        f"model      {model}",
        f"robot      tric_arm_hand (profile digest {RobotModel().profile.digest[:12]})",
        "kept",
        "selected",
        "chosen     the best of 2 candidates by the score 'landmarks'",
        "seed 3 ",
        "seed 4 ",
        "delta",
        "rho",
    ):
        assert expected in printed
    loaded = ModelFile.load(model)
    assert (
        loaded.info["hyperparameters"]["seed"] == 3
        and loaded.info["hyperparameters"]["hidden_units"] == 5
    )
    assert value_function(loaded).hidden_units == 5


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["{tmp}/missing.mcap"], "tric-train: {tmp}/missing.mcap does not exist"),
        (["{bags}", "--sigma", "0"], "tric-train: sigma must be in (0, 1] rad"),
        (["{bags}", "--members", "21"], "tric-train: members must be in [1, candidates (8)]"),
        (["{bags}", "--candidates", "0"], "tric-train: candidates must be in [1, 64]"),
        (
            ["{bags}", "--out", "{tmp}/model.json"],
            "tric-train: the model path {tmp}/model.json must end in .safetensors",
        ),
        (
            ["{bags}", "--kind", "dpl_finger", "--quiet"],
            "tric-train: dpl_finger needs the 'box' landmark and fingertip* landmarks (the "
            "open_box task); the feature definition of task 'grasp' has object, fingertip_1, "
            "fingertip_2, fingertip_3, finger_mid_1, finger_mid_2, finger_mid_3, palm",
        ),
    ],
)
def test_tric_train_refuses_bad_input_with_one_line(bag_dir, tmp_path, capsys, arguments, message):
    fill = lambda text: text.format(tmp=tmp_path, bags=bag_dir)  # noqa: E731
    status = train_cli.main(
        [fill(a) for a in arguments]
        + ([] if "--out" in arguments else ["--out", str(tmp_path / "m.safetensors")])
    )
    assert status == 2
    assert capsys.readouterr().err == fill(message) + "\n"
    assert not list(tmp_path.iterdir())


def test_tric_analyze_writes_its_figures(cli_run, bag_dir, tmp_path, capsys):
    _, _, model = cli_run
    assert (
        analyze_cli.main(
            [str(model), str(bag_dir), "--out", str(tmp_path / "figures"), "--top", "12"]
        )
        == 0
    )
    for name in (
        analysis.VALUE_FIGURE,
        analysis.COSINES_FIGURE,
        analysis.SCORES_FIGURE,
        analysis.GRADIENTS_FIGURE,
        analysis.SELECTION_FIGURE,
    ):
        assert (tmp_path / "figures" / name).read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    printed = capsys.readouterr().out
    assert (
        "mean cosine" in printed and "f falls on" in printed and "carry 95% of the score" in printed
    )
    assert "of 2 candidates from group 3 by the score 'landmarks' (s" in printed
    assert (
        analyze_cli.main(
            [str(tmp_path / "none.safetensors"), str(bag_dir), "--out", str(tmp_path / "x")]
        )
        == 2
    )
    assert "does not exist" in capsys.readouterr().err and not (tmp_path / "x").exists()
