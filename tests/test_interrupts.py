"""SIGINT and SIGTERM to the tools run as commands and to the nodes run as `ros2 run` runs them
(issue 25, item 2): each ends with one line and exit status 130 or 143, every finished bag
complete, the unfinished one only as .part, an earlier bag never replaced by a cut-short one, and
no result file written half."""

import contextlib
import json
import os
import pathlib
import select
import shutil
import signal
import subprocess
import sys
import tempfile

import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, rule

from conftest import HANG_S
from tric_learning.bags.info import bag_info


def finished_demonstration(bag) -> bool:
    """Whether bag is a whole demonstration: a finished MCAP file with the teacher's outcome."""
    info = bag_info(bag)
    return info.complete and "tric.outcome" in info.custom_data


def start(module: str, *arguments) -> subprocess.Popen:
    """The tool's module run as a command (argv from the command line), its stderr piped."""
    return subprocess.Popen(
        [sys.executable, "-m", module, *arguments],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONFAULTHANDLER": "1"},
    )


#: The workspace's node executables, as `ros2 run PKG NODE` starts them.
INSTALL = pathlib.Path(__file__).resolve().parent.parent / "ros_ws" / "install"
#: Each node: (package, executable, ROS arguments, the log line that ends its start).
NODES = {
    "simulator": ("tric_sim", [], "simulating '"),
    "teacher": ("tric_sim", [], "ready to demonstrate"),
    "visualizer": ("tric_sim", ["-p", "foxglove_port:=0"], "Foxglove server on ws://127.0.0.1:"),
    "recorder": ("tric_learning", ["-p", "output_dir:={tmp}"], "recording episodes of"),
    "trainer": ("tric_control", [], "ready to train"),
    "controller": ("tric_control", [], "controller for 'grasp'"),
}


def signal_after(process: subprocess.Popen, marker: str, count: int, signum: int) -> tuple:
    """Send signum once marker has appeared count times on the tool's stderr (read line by line:
    the wait ends on the event); (exit status, the rest of stderr)."""
    seen = 0
    for text in process.stderr:
        seen += marker in text
        if seen >= count:
            break
    assert seen >= count, f"the tool ended before {count} x {marker!r}"
    process.send_signal(signum)
    rest = process.communicate(timeout=HANG_S)[1]
    return process.returncode, rest


@pytest.mark.parametrize(
    "signum, status, word",
    [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")],
)
@pytest.mark.parametrize("node", list(NODES))
def test_a_node_ends_on_a_signal_with_one_line_and_its_status(tmp_path, node, signum, status, word):
    """A node spinning (its start logged) ends on SIGINT or SIGTERM with one line, the signal's
    exit status and no traceback (it exited 0 before, the controller once with a traceback)."""
    package, arguments, ready = NODES[node]
    process = subprocess.Popen(
        [str(INSTALL / package / "lib" / package / node), "--ros-args"]
        + [argument.format(tmp=tmp_path) for argument in arguments],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONFAULTHANDLER": "1"},
        cwd=tmp_path,
    )
    code, rest = signal_after(process, ready, 1, signum)
    assert (code, rest) == (status, f"{node}: {word}\n")


@pytest.mark.parametrize("node", ["simulator", "controller"])
def test_a_node_interrupted_during_its_imports_ends_with_one_line(tmp_path, node):
    """SIGINT while the node's module still imports its libraries (Python reports each import as
    it ends: the signal follows rclpy's first) ends it with one line and 130, no traceback (before:
    a KeyboardInterrupt traceback from the middle of an import)."""
    package = NODES[node][0]
    process = subprocess.Popen(
        [str(INSTALL / package / "lib" / package / node)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPROFILEIMPORTTIME": "1"},
        cwd=tmp_path,
    )
    code, rest = signal_after(process, "rclpy", 1, signal.SIGINT)
    lines = [line for line in rest.splitlines() if not line.startswith("import time:")]
    assert (code, lines) == (130, [f"{node}: interrupted"]), rest[-2000:]


@pytest.mark.parametrize(
    "signum, status, word",
    [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")],
)
def test_tric_record_interrupted_keeps_finished_bags_and_leaves_the_rest_as_part(
    tmp_path, signum, status, word
):
    out = tmp_path / "bags"
    recorder = start("tric_learning.record_cli", "sphere_train", "--out", str(out))
    code, rest = signal_after(recorder, "wrote ", 2, signum)
    assert code == status, rest
    lines = [line for line in rest.splitlines() if line.startswith("tric-record:")]
    assert lines == [f"tric-record: {word}; the bags of the finished demonstrations kept"], rest
    assert "Traceback" not in rest and "Fatal Python error" not in rest
    finished = sorted(out.glob("*.mcap"))
    assert len(finished) >= 2
    for bag in finished:
        assert finished_demonstration(bag), bag
    assert all(p.suffix in (".mcap", ".part") for p in out.iterdir())
    assert len(list(out.glob("*.part"))) <= 1


def test_tric_record_overwrite_terminated_keeps_the_earlier_bag(tmp_path):
    """--overwrite replaces a bag only once its successor is complete: a demonstration cut short
    leaves the earlier bag as it was, the new one as .part."""
    out = tmp_path / "bags"
    first = start("tric_learning.record_cli", "sphere_train", "--out", str(out))
    code, rest = signal_after(first, "wrote ", 3, signal.SIGINT)
    assert code == 130, rest
    earlier = sorted(bag.name for bag in out.glob("*.mcap"))
    again = start("tric_learning.record_cli", "sphere_train", "--out", str(out), "--overwrite")
    code, rest = signal_after(again, "demonstrating ", 1, signal.SIGTERM)
    assert code == 143, rest
    assert "tric-record: terminated; the bags of the finished demonstrations kept" in rest
    assert set(earlier) <= {bag.name for bag in out.glob("*.mcap")}
    for bag in out.glob("*.mcap"):
        assert finished_demonstration(bag), bag


def test_tric_eval_interrupted_keeps_its_episodes_and_resume_continues(tmp_path):
    """SIGTERM ends tric-eval --jobs 2 (its workers too) with the episodes judged so far in the
    --json file's .partial, no result, and nothing after its line (before: two lines about leaked
    semaphores); --resume runs only the others, and the result holds every episode in the
    situations' order."""
    out = tmp_path / "teacher.json"
    arguments = ["--teacher", "sphere_test", "--json", str(out), "--jobs", "2", "--offline"]
    evaluation = start("tric_control.evaluate_cli", *arguments)
    code, rest = signal_after(evaluation, "sphere_test_05", 1, signal.SIGTERM)
    assert code == 143, rest
    assert rest.rstrip("\n").endswith(
        "tric-eval: terminated; with --json, the episodes judged so far kept (--resume continues)"
    )
    for sign in ("Traceback", "Fatal Python error", "resource_tracker", "leaked"):
        assert sign not in rest, rest
    partial = tmp_path / "teacher.json.partial"
    assert sorted(p.name for p in tmp_path.iterdir()) == [partial.name]  # no result, no temporary
    kept = [e["record"]["situation"] for e in json.loads(partial.read_text())["episodes"]]
    assert 1 <= len(kept) < 15
    resumed = subprocess.run(
        [sys.executable, "-m", "tric_control.evaluate_cli", *arguments, "--resume"],
        capture_output=True,
        text=True,
        timeout=HANG_S * 3,
    )
    assert resumed.returncode == 0, resumed.stderr
    assert f"tric-eval: {len(kept)} episodes kept in {partial}" in resumed.stderr
    episodes = json.loads(out.read_text())["episodes"]
    assert [e["situation"] for e in episodes] == [f"sphere_test_{k:02d}" for k in range(15)]
    assert not partial.exists()


#: Seconds a tool's processes may take to end after the tool did.
ORPHAN_GRACE_S = 5.0


def processes_marked(mark: str) -> list:
    """The ids of the processes whose environment holds TRIC_TEST_MARK=mark."""
    found = []
    for folder in pathlib.Path("/proc").iterdir():
        try:
            if f"TRIC_TEST_MARK={mark}".encode() in (folder / "environ").read_bytes():
                found.append(int(folder.name))
        except (OSError, ValueError):  # not a process, one that ended, or not ours to read
            continue
    return found


def ends_within(pid: int, seconds: float) -> bool:
    """Whether the process pid ends (or has ended) within seconds, waiting on its pidfd."""
    try:
        pidfd = os.pidfd_open(pid)
    except ProcessLookupError:
        return True
    try:
        readable, _, _ = select.select([pidfd], [], [], seconds)
        return bool(readable)
    finally:
        os.close(pidfd)


@pytest.mark.slow
def test_tric_study_on_ray_terminated_leaves_no_ray_process(tmp_path, monkeypatch):
    """SIGTERM ends tric-study on its local Ray instance (its default) with the tool's line and
    143, and every process of that instance (Ray's daemons and workers inherit the tool's
    environment) ends with it."""
    mark = f"{os.getpid()}-{tmp_path.name}"
    monkeypatch.setenv("TRIC_TEST_MARK", mark)
    monkeypatch.chdir(pathlib.Path(__file__).resolve().parent.parent)  # bags/
    variant = "tiny=max_iterations=3,noisy_samples=3,grasp_steps=40"
    arguments = ["--variant", variant, "--tasks", "sphere", "--seeds", "0", "1"]
    study = start("tric_control.study.cli", *arguments, "--out", str(tmp_path), "--jobs", "2")
    code, rest = signal_after(study, "sphere_val", 1, signal.SIGTERM)
    assert code == 143, rest
    assert "tric-study: terminated; the rows measured so far kept in study.json" in rest
    # Ray's shutdown ends them as the tool exits (a few seconds' grace for their last moments,
    # each waited for on its pidfd); left to themselves, Ray's agents outlived the tool by a
    # minute or more
    outlived = [pid for pid in processes_marked(mark) if not ends_within(pid, ORPHAN_GRACE_S)]
    assert outlived == []


class RecordingInterrupted(RuleBasedStateMachine):
    """tric-record into one folder, again and again with --overwrite, each run ended by SIGINT or
    SIGTERM after a drawn number of its log lines (any moment: starting, demonstrating, writing a
    bag) or let finish: no finished bag is ever lost or left incomplete, and nothing unfinished
    carries a bag's final name."""

    def __init__(self):
        super().__init__()
        self.out = pathlib.Path(tempfile.mkdtemp(prefix="tric-interrupts-")) / "bags"
        self.finished = set()

    @rule(lines=st.integers(1, 40), signum=st.sampled_from([signal.SIGINT, signal.SIGTERM]))
    def record_and_interrupt(self, lines, signum):
        recorder = start(
            "tric_learning.record_cli", "sphere_train", "--out", str(self.out), "--overwrite"
        )
        seen = 0
        for _ in recorder.stderr:
            seen += 1
            if seen >= lines:
                recorder.send_signal(signum)
                break
        rest = recorder.communicate(timeout=HANG_S)[1]
        assert "Traceback" not in rest and "Fatal Python error" not in rest, rest
        if seen >= lines:
            assert recorder.returncode == 128 + signum, rest
        self.finished |= {bag.name for bag in self.out.glob("*.mcap")}

    @invariant()
    def finished_bags_stay_complete(self):
        if not self.out.exists():
            return
        names = {bag.name for bag in self.out.glob("*.mcap")}
        assert self.finished <= names
        for bag in self.out.glob("*.mcap"):
            assert finished_demonstration(bag), bag
        assert all(p.name.endswith((".mcap", ".mcap.part")) for p in self.out.iterdir())

    def teardown(self):
        shutil.rmtree(self.out.parent, ignore_errors=True)


RecordingInterrupted.TestCase.settings = settings(
    max_examples=2,
    stateful_step_count=3,
    deadline=None,
    derandomize=True,
    suppress_health_check=list(HealthCheck),
)
test_recording_interrupted_at_any_moment = RecordingInterrupted.TestCase


#: A tool whose worker process (calls_in_workers, as a study's or the experiments' trainings run)
#: has worker processes of its own (a training's forked sampling pool): it prints their ids on a
#: line of stdout, then waits.
WORKER_TREE = """
import os, sys, time
from tric_sim.tools.interrupts import end_commands_on_signals
from tric_control.evaluation.workers import calls_in_workers
from tric_learning.training.samples import worker_pool

def sleep(seconds):
    time.sleep(seconds)

def training():
    pool = worker_pool(2)
    started = [pool.submit(os.getpid) for _ in range(2)]  # the pool's processes are all up
    [future.result() for future in started]
    for _ in range(2):
        pool.submit(sleep, 600)
    print(" ".join(str(pid) for pid in [os.getpid(), *pool._processes]), flush=True)
    time.sleep(600)

if __name__ == "__main__":  # as a console script runs a tool: a spawned worker re-imports this
    end_commands_on_signals("tree")
    for _ in calls_in_workers(training, [()], 1, ()):
        pass
"""


def test_a_terminated_tool_s_workers_end_their_own_workers(tmp_path):
    """SIGTERM ends the tool, its worker and the worker's own workers: before, the tool ended its
    worker processes only, and a training's forked sampling workers ran on, orphaned, for an hour
    after `tric-experiments` was terminated."""
    script, stderr = tmp_path / "tree.py", tmp_path / "stderr"
    script.write_text(WORKER_TREE)
    # stderr to a file, and stdout read for one line only: a worker left running would hold a pipe
    # open past the tool's end
    pids: list = []
    with stderr.open("w") as file:
        tool = subprocess.Popen(
            [sys.executable, str(script)], stdout=subprocess.PIPE, stderr=file, text=True
        )
    try:
        pids = [int(pid) for pid in tool.stdout.readline().split()]
        assert len(pids) == 3, stderr.read_text()
        worker, *its_workers = pids
        tool.send_signal(signal.SIGTERM)
        tool.wait(timeout=HANG_S)
        rest = stderr.read_text()
        assert tool.returncode == 143 and "tree: terminated" in rest, rest
        outlived = [pid for pid in (worker, *its_workers) if not ends_within(pid, ORPHAN_GRACE_S)]
        assert outlived == []
    finally:
        tool.kill()
        tool.stdout.close()
        for pid in pids:
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
