"""The controller's real-time loop: a 100 Hz timer that must keep its period beside a simulator
running in real time, as a user runs TRIC against a robot.

The simulator node runs in a process of its own (`ros2 run tric_sim simulator`, mode realtime),
the controller node in this one (mode realtime, on the simulator's /clock; the sphere model
trained with the defaults on bags/sphere, not counted), spun by a SingleThreadedExecutor as
`ros2 run` spins it; a client node on an executor of its own resets the scene to a sphere test
situation and sends one episode of JITTER_TICKS ticks (min_steps too: at rest the controller
holds, gripped, and keeps ticking).

controller_jitter_p99_ms: p99 of |period - 10 ms| over the JITTER_TICKS periods between
  consecutive calls of the control timer (tric_control.loops.realtime) during the episode, ms.
  Target (issue 37): at most 1 on 2 cores. controller_jitter_p50_ms, controller_jitter_max_ms:
  its median and largest; controller_jitter_periods: how many periods were measured.
controller_jitter_events_p99_ms (and _p50_ms, _max_ms): the same with the controller node spun by
  rclpy's EventsExecutor (rclpy.experimental), in a process of its own that is killed if it has not
  ended within EVENTS_LIMIT_S; events_executor_stalled: 1 when it was (no jitter keys then), else 0.
  With rclpy 7.1.6 the controller's graph stalls under it (docs/decisions/episode-cost.md).

Run alone: python benchmarks/bench_realtime.py [--executor single_threaded|events] MODEL prints the
one executor's keys as JSON.
"""

import argparse
import json
import os
import pathlib
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np
import rclpy
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from tric_control.controller_node import ControllerNode
from tric_control.loops.realtime import RealtimeLoop
from tric_learning.training.value import TrainingConfig, train_from_bags
from tric_msgs.action import Execute
from tric_msgs.srv import ResetScene
from tric_sim.ros import messages
from tric_sim.ros.dds_domains import private_domain_id
from tric_sim.ros.graph import wait
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

BAGS = pathlib.Path(__file__).resolve().parent.parent / "bags" / "sphere"
JITTER_TICKS = 2000
PERIOD_S = 0.01
#: Seconds allowed for discovery, a service answer or the episode's end beyond its length.
WAIT_S = 30.0
#: Wall seconds the EventsExecutor's run has, in its own process, before it is taken for stalled.
EVENTS_LIMIT_S = 90.0


def executor_type(name: str):
    """The executor class of a name: "single_threaded" (what `ros2 run` spins a node with) or
    "events" (rclpy.experimental.EventsExecutor)."""
    if name == "events":
        from rclpy.experimental import EventsExecutor

        return EventsExecutor
    return SingleThreadedExecutor


def timed_control_timer(calls: list):
    """RealtimeLoop's control timer, appending the wall time of each call to calls first."""
    untimed = RealtimeLoop._on_control_timer

    def on_control_timer(loop):
        calls.append(time.perf_counter())
        untimed(loop)

    return untimed, on_control_timer


def call(client_node: Node, service_type, name: str, request):
    client = client_node.create_client(service_type, name)
    if not client.wait_for_service(timeout_sec=WAIT_S):
        raise RuntimeError(f"no {name} service after {WAIT_S:g} s")
    return wait(client.call_async(request), WAIT_S, name)


def episode_periods(model: pathlib.Path, domain_id: int, executor: str) -> np.ndarray:
    """The control timer's periods (s) during one realtime episode of JITTER_TICKS ticks, the
    controller node spun by the executor named (executor_type), the client by its own
    SingleThreadedExecutor."""
    ros2 = shutil.which("ros2")
    if ros2 is None:
        raise RuntimeError("ros2 is not on PATH: source env.sh first")
    environment = dict(os.environ, ROS_DOMAIN_ID=str(domain_id))
    environment.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    simulator = subprocess.Popen(
        [ros2, "run", "tric_sim", "simulator", "--ros-args", "-p", "mode:=realtime"],
        env=environment,
        stdout=subprocess.DEVNULL,
    )
    calls: list = []
    untimed, timed = timed_control_timer(calls)
    RealtimeLoop._on_control_timer = timed  # type: ignore[method-assign]
    context = Context()
    rclpy.init(context=context, domain_id=domain_id)
    try:
        controller = ControllerNode(
            context=context,
            parameter_overrides=[
                Parameter("mode", value="realtime"),
                Parameter("model_path", value=str(model)),
                # the simulator stamps its states with its own clock (controller_node's docstring)
                Parameter("use_sim_time", value=True),
            ],
        )
        client_node = Node("jitter_client", context=context)
        executors = [
            executor_type(executor)(context=context),
            SingleThreadedExecutor(context=context),
        ]
        for spinner, node in zip(executors, (controller, client_node)):
            spinner.add_node(node)
            threading.Thread(target=spinner.spin, daemon=True).start()
        situation = situations.dataset("sphere_test")[0]
        reset = call(
            client_node,
            ResetScene,
            "/simulator/reset_scene",
            ResetScene.Request(situation=messages.situation_to_msg(situation)),
        )
        if not reset.success:
            raise RuntimeError(f"the simulator refused the scene: {reset.message}")
        deadline = time.monotonic() + WAIT_S
        while controller.scene is None or controller.scene.situation != situation:
            if time.monotonic() > deadline:
                raise RuntimeError("the controller never received the situation")
            time.sleep(0.01)
        action = ActionClient(client_node, Execute, "/controller/execute")
        if not action.wait_for_server(timeout_sec=WAIT_S):
            raise RuntimeError("no /controller/execute action server")
        goal = Execute.Goal(max_steps=JITTER_TICKS, min_steps=JITTER_TICKS, episode_id="jitter")
        handle = wait(action.send_goal_async(goal), WAIT_S, "the goal's answer")
        if not handle.accepted:
            raise RuntimeError("the controller refused the episode")
        first = len(calls)
        # a loaded machine's simulator may run slower than real time: three times the episode
        length_s = 3 * JITTER_TICKS * PERIOD_S
        result = wait(handle.get_result_async(), length_s + WAIT_S, "the episode")
        ticks = calls[first:]
        print(
            f"[bench] realtime episode: {result.result.outcome}, {result.result.steps} steps, "
            f"{len(ticks)} timer calls",
            file=sys.stderr,
        )
        for spinner in executors:
            spinner.shutdown()
        controller.destroy_node()
        client_node.destroy_node()
    finally:
        simulator.terminate()
        simulator.wait(timeout=WAIT_S)
        RealtimeLoop._on_control_timer = untimed  # type: ignore[method-assign]
        context.try_shutdown()
    return np.diff(np.array(ticks))[:JITTER_TICKS]


def jitter_keys(periods: np.ndarray, infix: str = "") -> dict:
    """The jitter keys of periods (s): controller_jitter{infix}_p99_ms and its kin."""
    jitter_ms = np.abs(periods - PERIOD_S) * 1000.0
    return {
        f"controller_jitter{infix}_p99_ms": round(float(np.percentile(jitter_ms, 99)), 3),
        f"controller_jitter{infix}_p50_ms": round(float(np.median(jitter_ms)), 3),
        f"controller_jitter{infix}_max_ms": round(float(jitter_ms.max()), 3),
        f"controller_jitter{infix}_periods": int(len(periods)),
    }


def events_keys(model: pathlib.Path) -> dict:
    """The EventsExecutor's keys, measured in a process of its own (killed after EVENTS_LIMIT_S)."""
    command = [sys.executable, __file__, "--executor", "events", str(model)]
    # a session of its own, so that a stalled run is killed with its simulator
    process = subprocess.Popen(
        command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True
    )
    try:
        stdout, stderr = process.communicate(timeout=EVENTS_LIMIT_S)
    except subprocess.TimeoutExpired:
        os.killpg(process.pid, signal.SIGKILL)
        process.communicate()
        print(
            f"[bench] the EventsExecutor's episode did not end in {EVENTS_LIMIT_S:g} s: stalled",
            file=sys.stderr,
        )
        return {"events_executor_stalled": 1}
    if process.returncode != 0:
        last = (stderr.strip().splitlines() or ["no output"])[-1]
        print(f"[bench] the EventsExecutor's episode failed: {last}", file=sys.stderr)
        return {"events_executor_stalled": 1}
    keys = json.loads(stdout.strip().splitlines()[-1])
    return {**jitter_keys(np.array(keys["periods"]), "_events"), "events_executor_stalled": 0}


def run() -> dict:
    with tempfile.TemporaryDirectory() as folder:
        print("[bench] training the sphere model ...", file=sys.stderr, flush=True)
        model = train_from_bags(
            [BAGS], pathlib.Path(folder) / "sphere.safetensors", TrainingConfig(), RobotModel()
        ).path
        periods = episode_periods(pathlib.Path(model), private_domain_id(), "single_threaded")
        events = events_keys(pathlib.Path(model))
    return {**jitter_keys(periods), **events}


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description="one realtime episode's control periods")
    parser.add_argument("--executor", choices=("single_threaded", "events"), required=True)
    parser.add_argument("model", type=pathlib.Path)
    args = parser.parse_args()
    measured = episode_periods(args.model, private_domain_id(), args.executor)
    print(json.dumps({"periods": measured.tolist()}))
