"""One writer per output (issue 38): two runs naming one --json file, one model path or one bag
folder, and exactly one of them writes it; the other is refused before any work with one line
naming the first one's PID (before: both wrote, one result lost, both exit 0).

The first run is the tool's own code in this process, held in the middle of its work (its
episodes, its training, its demonstrations) until the second, a real command, has been answered;
the last test races two commands as a user would start them."""

import json
import os
import subprocess
import sys
import threading

import pytest
from demo_bags import sphere, write_demo_bag

from conftest import HANG_S
from tric_control import evaluate_cli, train_cli
from tric_control.evaluation import offline
from tric_control.experiments import cli as experiments_cli
from tric_control.study import cli as study_cli
from tric_learning import analyze_cli, demonstrations, record_cli
from tric_learning.training import dpl
from tric_sim import snapshot
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation_files import save_situations
from tric_sim.world.situations import dataset


def command(module: str, *arguments, **options) -> subprocess.CompletedProcess:
    """The tool's module run as a command, to its end."""
    return subprocess.run(
        [sys.executable, "-m", module, *arguments],
        capture_output=True,
        text=True,
        timeout=HANG_S,
        **options,
    )


class HeldRun:
    """tool_main(arguments) run on a thread of this process, its work held at a point the test
    patches in (hold()) until release(); status: its exit status once it ended."""

    def __init__(self, tool_main, arguments):
        self.started, self.released = threading.Event(), threading.Event()
        self.status = None
        self.thread = threading.Thread(target=self._run, args=(tool_main, arguments))

    def _run(self, tool_main, arguments):
        self.status = tool_main(arguments)

    def hold(self):
        self.started.set()
        assert self.released.wait(HANG_S), "the held run was never released"

    def __enter__(self):
        self.thread.start()
        assert self.started.wait(HANG_S), "the held run never reached its work"
        return self

    def __exit__(self, *_):
        self.released.set()
        self.thread.join(HANG_S)
        assert not self.thread.is_alive()


def refusal(what: str, path) -> str:
    return (
        f"{what} {path} is being written by another run (PID {os.getpid()}): wait for it to end, "
        "or give another path\n"
    )


def test_two_runs_on_one_json_file(tmp_path, monkeypatch):
    situations = tmp_path / "s.yaml"
    save_situations(situations, dataset("sphere_test")[:2])
    out = tmp_path / "r.json"
    evaluate = offline.evaluate_offline
    run = HeldRun(
        evaluate_cli.main,
        ["--teacher", "--situations-file", str(situations), "--offline", "--json", str(out)],
    )

    def held(*args, **kwargs):
        run.hold()
        return evaluate(*args, **kwargs)

    monkeypatch.setattr(offline, "evaluate_offline", held)
    with run:
        second = command(
            "tric_control.evaluate_cli",
            *("--teacher", "--situations-file", str(situations), "--offline"),
            *("--json", str(out), "--overwrite"),
        )
    assert (second.returncode, second.stderr) == (2, "tric-eval: " + refusal("--json file", out))
    assert run.status == 0
    assert json.loads(out.read_text())["agent"] == "teacher"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "s.yaml"]


def test_two_runs_on_one_model_path(tmp_path, monkeypatch):
    robot = RobotModel()
    bags = tmp_path / "bags"
    for k in range(2):
        write_demo_bag(bags / f"demo_{k}.mcap", robot, sphere(f"demo_{k}"))
    out = tmp_path / "m.safetensors"
    tiny = ["--kind", "dpl_joint", "--iterations", "2", "--hidden-units", "4", "--quiet"]
    run = HeldRun(train_cli.main, [str(bags), "--out", str(out), "--seed", "1", *tiny])
    train = dpl.train_dpl

    def held(*args, **kwargs):
        run.hold()
        return train(*args, **kwargs)

    monkeypatch.setattr(dpl, "train_dpl", held)
    with run:
        second = command(
            "tric_control.train_cli", str(bags), "--out", str(out), "--seed", "2", *tiny
        )
    assert (second.returncode, second.stderr) == (
        2,
        "tric-train: " + refusal("the model path", out),
    )
    assert run.status == 0
    assert out.is_file() and sorted(p.name for p in tmp_path.iterdir()) == ["bags", out.name]


def test_two_runs_on_one_bag_folder(tmp_path, monkeypatch):
    situations = tmp_path / "s.yaml"
    chosen = dataset("sphere_train")[:2]
    save_situations(situations, chosen)
    out = tmp_path / "bags"
    run = HeldRun(record_cli.main, ["--situations-file", str(situations), "--out", str(out)])
    robot = RobotModel()

    def held(situations, folder, *args, **kwargs):
        run.hold()
        return [(s, _Done(), write_demo_bag(folder / f"{s.name}.mcap", robot, s)) for s in chosen]

    monkeypatch.setattr(demonstrations, "demonstrate_all", held)
    with run:
        second = command(
            "tric_learning.record_cli",
            *("--situations-file", str(situations), "--out", str(out), "--overwrite"),
        )
    assert (second.returncode, second.stderr) == (2, "tric-record: " + refusal("--out folder", out))
    assert run.status == 0
    assert sorted(p.name for p in out.iterdir()) == [f"{s.name}.mcap" for s in chosen]


class _Done:
    """A demonstration's result as the table prints it: a success."""

    success, message = True, ""

    class metrics:
        success, grasp_cost, lift_passed, lid_angle = True, 0.0, True, 0.0


def test_two_commands_started_together_and_one_json_file(tmp_path):
    """The issue's case: two evaluations into one file (here of other situations), started at
    once: exactly one writes it, the other is refused with one line (naming the first one's PID
    when their runs overlap, the file it found when they did not), and the file holds the
    winner's episodes."""
    out = tmp_path / "r.json"
    runs = {}
    for name in ("sphere_test", "sphere_val"):
        situations = tmp_path / f"{name}.yaml"
        save_situations(situations, dataset(name)[:3])
        runs[name] = subprocess.Popen(
            [sys.executable, "-m", "tric_control.evaluate_cli", "--teacher", "--offline"]
            + ["--situations-file", str(situations), "--json", str(out)],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
    ended = {name: (run.wait(HANG_S), run.stderr.read()) for name, run in runs.items()}
    assert sorted(status for status, _ in ended.values()) == [0, 2], ended
    [winner] = [name for name, (status, _) in ended.items() if status == 0]
    [error] = [error for status, error in ended.values() if status == 2]
    assert error.count("\n") == 1 and error.startswith(f"tric-eval: --json file {out}")
    assert f"(PID {runs[winner].pid})" in error or "exists; give --overwrite" in error
    episodes = json.loads(out.read_text())["episodes"]
    assert [e["situation"] for e in episodes] == [s.name for s in dataset(winner)[:3]]


def hold_claim(path, folder: bool) -> subprocess.Popen:
    """Another process holding a claim on path until its stdin closes (it says "held" first)."""
    code = (
        "import sys\nfrom tric_sim.tools.claims import claim\n"
        f"c = claim({str(path)!r}, folder={folder})\nprint('held', flush=True)\nsys.stdin.read()\n"
    )
    process = subprocess.Popen(
        [sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    assert process.stdout.readline() == "held\n"
    return process


@pytest.mark.parametrize(
    "tool, arguments, what",
    [
        (experiments_cli, ["table1", "--executor", "processes"], "--out folder"),
        (experiments_cli, ["--report-only"], "--out folder"),
        (study_cli, ["--tasks", "sphere", "--executor", "processes"], "--out folder"),
        (analyze_cli, ["m.safetensors", "b.mcap"], "--out folder"),
        (snapshot, ["sphere_grid_00"], "--out folder"),
    ],
)
def test_a_folder_another_run_writes_is_refused_before_work(
    tmp_path, capsys, tool, arguments, what
):
    """Experiment, study, analysis and picture folders: one line naming the other run's PID."""
    out = tmp_path / "out"
    holder = hold_claim(out, folder=True)
    try:
        assert tool.main([*arguments, "--out", str(out)]) == 2
    finally:
        holder.stdin.close()
        holder.wait(HANG_S)
    error = capsys.readouterr().err
    assert error.endswith(
        f"{what} {out} is being written by another run (PID {holder.pid}): wait for it to end, "
        "or give another path\n"
    )
    assert error.count("\n") == 1
