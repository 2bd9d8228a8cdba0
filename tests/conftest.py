"""Fixtures for in-process ROS 2 tests: a fresh rclpy context and a spinning executor per test, and
TRIC trained on the reference sphere bags once per session; helpers to wait, call and compare.

Every wait here ends on an event, never on a poll: wait_for re-checks its predicate each time a
Condition is notified, and the spin fixture notifies STATE_CHANGED after every callback that the
test's executor runs (a message taken, a timer, a service answer, a matched event), so a predicate
over what those callbacks change is checked as soon as it may have become true. State changed by a
thread of its own has its own Condition (RecorderNode.changed); files written by another process
are followed with inotify (FolderChanges)."""

import ctypes
import dataclasses
import json
import math
import os
import pathlib
import select
import threading
import time

import pytest
import rclpy
from rclpy.context import Context
from rclpy.event_handler import EventHandler, QoSPublisherEventType
from rclpy.executors import SingleThreadedExecutor

from tric_learning import model_file
from tric_learning.training.value import TrainingConfig, train_from_bags
from tric_sim.world.robot_model import RobotModel

#: Wall seconds after which a wait counts as a hang. Far more than any of these waits takes on a
#: loaded machine: it only keeps a broken test from waiting for ever, and times nothing.
HANG_S = 120.0
#: Control periods (10 ms each, at least) that an absence check lets the graph run before it looks.
ABSENCE_PERIODS = 50
#: The reference demonstrations shipped with the repository (bags/README.md).
REFERENCE_BAGS = pathlib.Path(__file__).resolve().parent.parent / "bags"
#: Notified after every callback the spin fixture's executor runs: wait_for's default Condition.
STATE_CHANGED = threading.Condition()


@pytest.fixture(scope="session")
def reference_sphere_training(tmp_path_factory):
    """TRIC trained with TrainingConfig()'s defaults on the 27 reference sphere demonstrations
    (bags/sphere), as tric-demo --reuse trains it: a training.BagTraining, made once per session for
    the tests that need a model that grasps."""
    return train_from_bags(
        [REFERENCE_BAGS / "sphere"],
        tmp_path_factory.mktemp("reference") / "tric_sphere.safetensors",
        TrainingConfig(),
        RobotModel(),
    )


@pytest.fixture
def ros_context():
    """An initialized rclpy Context of its own, shut down after the test."""
    context = Context()
    rclpy.init(context=context)
    yield context
    context.try_shutdown()


@pytest.fixture
def executor(ros_context):
    """A SingleThreadedExecutor (the one `ros2 run` uses) on the test's context; nodes added to it
    are destroyed afterwards."""
    exe = SingleThreadedExecutor(context=ros_context)
    yield exe
    for node in list(exe.get_nodes()):
        exe.remove_node(node)
        node.destroy_node()
    exe.shutdown()


@pytest.fixture
def spin(executor):
    """spin(*nodes): add nodes to the test's executor and spin it in a background thread, which
    notifies STATE_CHANGED after every callback it runs; the thread is stopped and joined after the
    test, before the executor fixture destroys the nodes and the executor (Executor.shutdown() while
    another thread spins can destroy what that thread uses)."""
    stop, started = threading.Event(), []

    def spin_until_stopped():
        while not stop.is_set():
            executor.spin_once()  # returns once it has run a callback
            with STATE_CHANGED:
                STATE_CHANGED.notify_all()

    def start(*nodes):
        for node in nodes:
            executor.add_node(node)
        if not started:
            thread = threading.Thread(target=spin_until_stopped, daemon=True)
            thread.start()
            started.append(thread)
        return nodes[0] if len(nodes) == 1 else nodes

    yield start
    stop.set()
    executor.create_task(lambda: None)  # a callback to run: the spinning thread sees stop
    for thread in started:
        thread.join(HANG_S)


def wait_for(predicate, timeout=HANG_S, what="condition", changed=STATE_CHANGED):
    """predicate()'s first truthy value, checked now and each time the Condition changed is
    notified (by default after every callback of the spin fixture's executor), holding its lock;
    an AssertionError after timeout s."""
    with changed:
        value = changed.wait_for(predicate, timeout)
    assert value, f"timed out after {timeout} s waiting for {what}"
    return value


def publisher_matches(node, publisher):
    """A function giving how many subscriptions publisher has matched (DDS: its messages now reach
    them), as its matched events report them. The events are handled by node's executor, so a
    wait_for on it ends on them. publisher may be another node's, made without event callbacks:
    an event that came before this call is still reported."""
    matched = [0]

    def on_matched(status):
        matched[0] = status.current_count

    node.add_waitable(
        EventHandler(
            callback_group=node.default_callback_group,
            callback=on_matched,
            event_type=QoSPublisherEventType.RCL_PUBLISHER_MATCHED,
            parent_impl=publisher.handle,
        )
    )
    return lambda: matched[0]


class FolderChanges:
    """The kernel's notices (inotify) of files created, written, closed or renamed in a folder,
    for following what another process writes there: wait_for re-checks its predicate on each."""

    _MASK = 0x002 | 0x008 | 0x080 | 0x100  # IN_MODIFY, IN_CLOSE_WRITE, IN_MOVED_TO, IN_CREATE

    def __init__(self, folder: pathlib.Path):
        libc = ctypes.CDLL(None, use_errno=True)
        self._fd = libc.inotify_init1(os.O_NONBLOCK | os.O_CLOEXEC)
        if self._fd < 0 or libc.inotify_add_watch(self._fd, os.fsencode(folder), self._MASK) < 0:
            raise OSError(ctypes.get_errno(), f"cannot watch {folder}")

    def wait_for(self, predicate, process, timeout=HANG_S, what="condition"):
        """predicate()'s first truthy value, checked now and after each change in the folder;
        an AssertionError when process (a subprocess.Popen) ends first or after timeout s."""
        ended = os.pidfd_open(process.pid)
        deadline = time.monotonic() + timeout
        try:
            while not (value := predicate()):
                remaining = deadline - time.monotonic()
                ready = select.select([self._fd, ended], [], [], max(remaining, 0))[0]
                assert ready, f"timed out after {timeout} s waiting for {what}"
                assert ended not in ready, f"the process ended before {what}"
                while True:  # take every notice: each has been seen by the next check
                    try:
                        os.read(self._fd, 65536)
                    except BlockingIOError:
                        break
            return value
        finally:
            os.close(ended)

    def close(self):
        os.close(self._fd)


def wait_future(future, timeout=HANG_S, what="future"):
    """Wait for an rclpy future (its node spun elsewhere) through its done callback; its result,
    or an AssertionError after timeout s."""
    done = threading.Event()
    future.add_done_callback(lambda _: done.set())
    assert done.wait(timeout), f"timed out after {timeout} s waiting for {what}"
    return future.result()


def call(node, srv_type, name, request, timeout=HANG_S):
    """Call a service from node (spun elsewhere) and return the response."""
    client = node.create_client(srv_type, name)
    assert client.wait_for_service(timeout_sec=timeout), f"service {name} not available"
    response = client.call(request, timeout_sec=timeout)
    assert response is not None, f"service {name} did not answer in {timeout} s"
    node.destroy_client(client)
    return response


def run_action(node, action_type, name, goal, timeout=HANG_S):
    """Send a goal from node (spun elsewhere); returns (status, result, feedback messages)."""
    from rclpy.action import ActionClient

    client = ActionClient(node, action_type, name)
    assert client.wait_for_server(timeout_sec=HANG_S), f"action server {name} not available"
    feedback = []
    goal_future = client.send_goal_async(
        goal, feedback_callback=lambda msg: feedback.append(msg.feedback)
    )
    handle = wait_future(goal_future, HANG_S, "goal response")
    if not handle.accepted:
        client.destroy()
        return None, None, feedback
    result_future = handle.get_result_async()
    wrapped = wait_future(result_future, timeout, f"the result of {name}")
    client.destroy()
    return wrapped.status, wrapped.result, feedback


def run_periods(node, periods=ABSENCE_PERIODS, period_s=0.01):
    """Let the graph run: return once a timer of node (spun elsewhere) has fired periods times, one
    every period_s s at most. An absence check calls this first, so that whatever the graph would
    publish has had those periods to arrive."""
    fired = []
    timer = node.create_timer(period_s, lambda: fired.append(None))
    try:
        wait_for(lambda: len(fired) >= periods, what=f"{periods} timer periods")
    finally:
        node.destroy_timer(timer)


def record_fields(record) -> dict:
    """An EpisodeRecord's fields but its wall time, NaN written as the string "nan" (NaN != NaN):
    two runs of a deterministic episode give equal ones."""
    fields = dataclasses.asdict(record)
    del fields["wall_time_s"]
    return {k: "nan" if isinstance(v, float) and math.isnan(v) else v for k, v in fields.items()}


def study_results(folder) -> dict:
    """A tric-study folder's rows and failed cells without their timings (the candidates' too),
    and its models' arrays: two runs of one study give equal ones."""
    results = json.loads((folder / "study.json").read_text())
    rows = {}
    timings = ("train_s", "rollout_s", "time_share")
    for name, row in results["rows"].items():
        model = {k: v for k, v in row["model"].items() if k not in timings}
        selection = {
            **row["selection"],
            "candidates": [
                {k: v for k, v in c.items() if k not in timings}
                for c in row["selection"]["candidates"]
            ],
        }
        rows[name] = {**row, "model": model, "selection": selection, "date": None}
    arrays = {
        path.name: {k: v.tobytes() for k, v in model_file.ModelFile.load(path).arrays.items()}
        for path in sorted((folder / "models").iterdir())
    }
    return {"rows": rows, "failed": results["failed"], "arrays": arrays}
