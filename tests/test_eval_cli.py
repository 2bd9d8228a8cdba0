"""tric-eval refuses what it cannot do before the first episode, and its --resume knows what it
resumes: a resume after the model, a situation or the step budget changed runs again exactly the
episodes that changed, naming them (issue 38); its result never replaces a file that appeared
while it worked unless --overwrite."""

import dataclasses
import json
import os

import pytest
import yaml
from demo_bags import sphere, write_demo_bag

from tric_control import evaluate_cli, train_cli
from tric_control.evaluation import offline
from tric_learning.model_file import ModelFile
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation_files import save_situations
from tric_sim.world.situations import dataset

#: Control ticks per episode here: enough to be judged, short enough for a test.
TICKS = "20"
#: Why --resume runs an episode again that ran another way (tric_control.evaluation.partial).
ANOTHER_WAY = (
    "it ran another way (through the nodes or offline, on another robot, or with other controller "
    "settings)"
)


@pytest.fixture(scope="module")
def models(tmp_path_factory):
    """Two model files of one shape but other weights (a tiny training on hand-made bags, and the
    same model with one array changed)."""
    folder = tmp_path_factory.mktemp("models")
    robot = RobotModel()
    for k in range(2):
        write_demo_bag(folder / "bags" / f"demo_{k}.mcap", robot, sphere(f"demo_{k}"))
    first = folder / "first.safetensors"
    arguments = ["--iterations", "2", "--noisy-samples", "2", "--hidden-units", "0", "--quiet"]
    assert train_cli.main([str(folder / "bags"), "--out", str(first), *arguments]) == 0
    model = ModelFile.load(first)
    model.arrays["w3"] = model.arrays["w3"] * 1.5
    second = model.save(folder / "second.safetensors")
    return first, second


def interrupt_after(monkeypatch, episodes: int) -> None:
    """Ctrl-C as the given number of episodes have been judged (and kept)."""
    evaluate = offline.evaluate_offline

    def interrupted(situations, *args, on_record=None, **kwargs):
        judged = []

        def keep(record):
            on_record(record)
            judged.append(record)
            if len(judged) == episodes:
                raise KeyboardInterrupt

        return evaluate(situations, *args, on_record=keep, **kwargs)

    monkeypatch.setattr(offline, "evaluate_offline", interrupted)


def evaluation(model, situations_file, out, *more) -> list:
    return ["--model", str(model), "--situations-file", str(situations_file), "--offline"] + [
        "--json",
        str(out),
        "--max-steps",
        TICKS,
        *more,
    ]


@pytest.mark.parametrize("change", ["model", "situation", "budget", "pace"])
def test_a_resume_after_a_change_reruns_exactly_what_changed(
    tmp_path, models, monkeypatch, capsys, change
):
    """Interrupted after two episodes; then the model file replaced by another, or the second
    situation moved 15 cm in the YAML, or the step budget changed, or the controller's fall pace
    turned off (the paper's constant delta): --resume keeps the episodes
    still made as asked, runs exactly the others again and names them (before: "2 episodes kept",
    and a result mixing the old model's costs with the new one's)."""
    first, second = models
    situations = dataset("sphere_test")[:3]
    path, out, model = tmp_path / "s.yaml", tmp_path / "r.json", tmp_path / "m.safetensors"
    save_situations(path, situations)
    model.write_bytes(first.read_bytes())
    interrupt_after(monkeypatch, 2)
    assert evaluate_cli.main(evaluation(model, path, out)) == 130
    assert not out.exists()
    monkeypatch.undo()
    ran = []
    monkeypatch.setattr(offline, "evaluate_offline", _counting(ran))
    capsys.readouterr()
    budget, more = TICKS, []
    if change == "model":
        model.write_bytes(second.read_bytes())  # the same path, another model
        rerun, why = ["sphere_test_00", "sphere_test_01", "sphere_test_02"], "the model changed"
    elif change == "situation":
        x, y, z = situations[1].object_position
        moved = dataclasses.replace(situations[1], object_position=(x, y + 0.15, z))
        save_situations(path, [situations[0], moved, situations[2]])
        rerun, why = ["sphere_test_01", "sphere_test_02"], "the situation changed"
    elif change == "budget":
        budget = "30"
        rerun, why = (
            ["sphere_test_00", "sphere_test_01", "sphere_test_02"],
            "the step budget changed",
        )
    else:
        more = ["--fall-pace-knee", "0"]
        rerun = ["sphere_test_00", "sphere_test_01", "sphere_test_02"]
        why = ANOTHER_WAY
    arguments = evaluation(model, path, out, "--resume", *more)
    arguments[arguments.index("--max-steps") + 1] = budget
    assert evaluate_cli.main(arguments) == 0
    assert ran == [rerun]
    error = capsys.readouterr().err
    dropped = [name for name in rerun if name != "sphere_test_02"]
    assert f"made otherwise, run again: {', '.join(f'{n} ({why})' for n in dropped)}\n" in error
    episodes = json.loads(out.read_text())["episodes"]
    assert [e["situation"] for e in episodes] == [s.name for s in situations]
    assert all(e["steps"] <= int(budget) for e in episodes)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["m.safetensors", "r.json", "s.yaml"]


def _counting(runs: list):
    evaluate = offline.evaluate_offline

    def counting(situations, *args, **kwargs):
        runs.append([situation.name for situation in situations])
        return evaluate(situations, *args, **kwargs)

    return counting


def test_an_unchanged_resume_runs_only_what_was_not_judged(tmp_path, models, monkeypatch, capsys):
    first, _ = models
    path, out = tmp_path / "s.yaml", tmp_path / "r.json"
    save_situations(path, dataset("sphere_test")[:3])
    interrupt_after(monkeypatch, 1)
    assert evaluate_cli.main(evaluation(first, path, out)) == 130
    monkeypatch.undo()
    ran = []
    monkeypatch.setattr(offline, "evaluate_offline", _counting(ran))
    capsys.readouterr()
    assert evaluate_cli.main(evaluation(first, path, out)) == 2  # no --resume, no --overwrite
    assert capsys.readouterr().err == (
        f"tric-eval: {out}.partial holds the episodes of an interrupted run: give --resume to "
        "continue it, or --overwrite to start anew\n"
    )
    assert evaluate_cli.main(evaluation(first, path, out, "--resume")) == 0
    assert ran == [["sphere_test_01", "sphere_test_02"]]
    assert f"tric-eval: 1 episodes kept in {out}.partial\n" in capsys.readouterr().err


def test_a_result_never_replaces_a_file_that_appeared_meanwhile(tmp_path, models, monkeypatch):
    """Another program writes the --json file while the episodes run: without --overwrite it is
    left as it was, the result goes beside it, one line, exit 2, and the episodes stay kept."""
    first, _ = models
    out = tmp_path / "r.json"
    evaluate = offline.evaluate_offline

    def meanwhile(situations, *args, **kwargs):
        out.write_text("another program's")
        return evaluate(situations, *args, **kwargs)

    monkeypatch.setattr(offline, "evaluate_offline", meanwhile)
    arguments = ["--model", str(first), "sphere_test", "--offline", "--max-steps", TICKS]
    assert evaluate_cli.main([*arguments, "--json", str(out)]) == 2
    assert out.read_text() == "another program's"
    assert len(json.loads((tmp_path / "r.new.json").read_text())["episodes"]) == 15
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "r.json.partial", "r.new.json"]


def test_a_step_budget_past_the_goal_s_field_is_refused(capsys):
    """Through the nodes, 10^20 steps ended in a SystemError from the Execute goal's uint32."""
    with pytest.raises(SystemExit) as ended:
        evaluate_cli.main(["--teacher", "sphere_test", "--max-steps", str(10**20)])
    assert ended.value.code == 2
    assert capsys.readouterr().err.endswith(
        f"tric-eval: error: --max-steps must be in [0, {2**32 - 1}] (0: the controller's default)\n"
    )


#: How tric-eval refuses a controller setting beside the paper's protocol.
PAPER_SETS = "not with --max-steps, --fall-pace-knee or --stall-escapes"


@pytest.mark.parametrize(
    "arguments, message",
    [
        (["--fall-pace-knee", "1.5"], "--fall-pace-knee must be in [0, 1]"),
        (["--fall-pace-knee", "-0.1"], "--fall-pace-knee must be in [0, 1]"),
        (["--stall-escapes", "-1"], "--stall-escapes must be >= 0"),
        (["--protocol", "paper", "--fall-pace-knee", "0.5"], PAPER_SETS),
        (["--protocol", "paper", "--max-steps", "800"], PAPER_SETS),
        (["--protocol", "paper", "--stall-escapes", "3"], PAPER_SETS),
    ],
)
def test_a_controller_setting_out_of_range_or_beside_the_paper_s_protocol_is_refused(
    arguments, message, capsys
):
    with pytest.raises(SystemExit) as ended:
        evaluate_cli.main(["--teacher", "sphere_test", *arguments])
    assert ended.value.code == 2
    assert message in capsys.readouterr().err


def test_tric_eval_refuses_before_work(tmp_path, monkeypatch, capsys):
    """Each refused with one line and exit 2, no episode run and nothing written: a device or a
    pipe given as a model (said to "not exist" before), a --json name whose .partial is too long
    (a traceback before), a situations file with a start outside the joint limits (found after
    the situations before it had run, naming neither situation nor file)."""

    def never(*_, **__):
        raise AssertionError("an episode ran")

    monkeypatch.setattr(offline, "evaluate_offline", never)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    entries = [s.to_dict() for s in dataset("sphere_test")[:2]]
    entries[1]["name"], entries[1]["initial_joint_positions"] = "bad_start", [3.1] + [0.0] * 13
    bad = tmp_path / "bad.yaml"
    bad.write_text(yaml.safe_dump({"situations": entries}))
    long_json = tmp_path / ("j" * 245 + ".json")
    refusals = [
        (["--model", "/dev/zero", "sphere_test"], "model file /dev/zero is not a regular file"),
        (["--model", str(fifo), "sphere_test"], f"model file {fifo} is not a regular file"),
        (["--teacher", "sphere_test", "--json", str(long_json)], "bytes the file system takes"),
        (
            ["--teacher", "--situations-file", str(bad)],
            f"situations file {bad}: situation 'bad_start': initial_joint_positions: arm_1_joint "
            "= 3.1000 rad is outside its limits",
        ),
    ]
    for arguments, message in refusals:
        assert evaluate_cli.main([*arguments, "--offline"]) == 2
        error = capsys.readouterr().err
        assert error.startswith("tric-eval: ") and message in error, error
        assert error.count("\n") == 1
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.yaml", "fifo"]
