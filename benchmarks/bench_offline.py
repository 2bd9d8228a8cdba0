"""Offline evaluation against the nodes, and the offline path against its floor.

nodes_over_offline: the wall time of a TRIC model on the 15 sphere_test situations through the
  nodes (tric-eval: simulator, controller and client in one process, lockstep, one graph), divided
  by the same episodes offline (tric-eval --offline: the controller core on PhysicsWorld, one
  process). Target (docs/design.md): at most 1.5. offline_sphere_test_s and nodes_sphere_test_s
  give both times; offline_period_us and nodes_period_us the wall time per control period (the
  episodes' ticks summed, the scene's reset and the judge, lift test included, spread over them).
offline_over_floor: the offline control loop's period over the sum of its two parts, measured in
  the same episodes: the physics (PhysicsWorld.step) and the controller's tick
  (MotionRateController.tick). Target: at most 1.15, what the offline path adds beyond what it
  must do. offline_loop_period_us, offline_physics_us, offline_tick_us: the three, per period;
  offline_judge_us and offline_reset_us: the judge (its lift test's physics included) and the
  scene's reset, per period of the episodes, outside the loop. nodes_loop_period_us and its kin:
  the same parts through the nodes, in a run of their own: what a period through the nodes costs
  beyond them is the ROS part (messages, their conversions, the waits between threads). The parts
  are timed in the same runs, by wrapping the methods (a perf_counter pair costs well under a
  microsecond, against periods of hundreds).
Training the model (the paper's defaults on bags/sphere) is not counted.
"""

import contextlib
import functools
import pathlib
import sys
import tempfile
import threading
import time

from tric_control.evaluation import offline as offline_path
from tric_control.evaluation.graph import evaluate
from tric_control.evaluation.offline import evaluate_offline
from tric_control.motion_rate import MotionRateController
from tric_learning.training.value import TrainingConfig, train_from_bags
from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.ros.dds_domains import private_domain_id
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

BAGS = pathlib.Path(__file__).resolve().parent.parent / "bags" / "sphere"


#: Whether this thread is inside a timed call.
_inside = threading.local()


@contextlib.contextmanager
def timed(owner, name: str, seconds: dict, key: str):
    """owner.name wrapped, for the block, to add the wall time of each call to seconds[key]
    (calls made inside another timed call of the same thread are counted there, not here)."""
    untimed = getattr(owner, name)
    seconds.setdefault(key, 0.0)

    @functools.wraps(untimed)
    def wrapper(*args, **kwargs):
        if getattr(_inside, "value", False):
            return untimed(*args, **kwargs)
        _inside.value = True
        start = time.perf_counter()
        try:
            return untimed(*args, **kwargs)
        finally:
            seconds[key] += time.perf_counter() - start
            _inside.value = False

    setattr(owner, name, wrapper)
    try:
        yield
    finally:
        setattr(owner, name, untimed)


@contextlib.contextmanager
def parts_timed(parts: dict):
    """The block's physics steps, scene resets, controller ticks and judging timed into parts
    (seconds by key), wherever they run (the nodes' threads included)."""
    with (
        timed(PhysicsWorld, "step", parts, "physics"),
        timed(PhysicsWorld, "reset", parts, "reset"),
        timed(MotionRateController, "tick", parts, "tick"),
        timed(offline_path.metrics, "evaluate", parts, "judge"),
    ):
        yield


def loop_keys(prefix: str, wall_s: float, steps: int, parts: dict) -> dict:
    """A path's control loop against its floor: {prefix}_loop_period_us (the wall time per
    period, the judge and the resets left out), {prefix}_physics_us, {prefix}_tick_us,
    {prefix}_judge_us, {prefix}_reset_us (per period)."""
    per_period = {key: value / steps * 1e6 for key, value in parts.items()}
    loop_us = wall_s / steps * 1e6 - per_period["judge"] - per_period["reset"]
    keys = {f"{prefix}_loop_period_us": round(loop_us, 1)}
    keys.update({f"{prefix}_{key}_us": round(value, 1) for key, value in per_period.items()})
    return keys


def run() -> dict:
    tests = situations.dataset("sphere_test")
    with tempfile.TemporaryDirectory() as folder:
        print("[bench] training the sphere model ...", file=sys.stderr, flush=True)
        model = train_from_bags(
            [BAGS], pathlib.Path(folder) / "sphere.safetensors", TrainingConfig(), RobotModel()
        ).path
        runs = {}
        for path in ("offline", "nodes"):
            parts: dict = {}
            with parts_timed(parts):
                start = time.perf_counter()
                if path == "offline":
                    records = evaluate_offline(tests, str(model), progress=False)
                else:
                    records = evaluate(tests, model, progress=False, domain_id=private_domain_id())
                runs[path] = (time.perf_counter() - start, records, parts)
    (offline_s, offline, _), (nodes_s, nodes, _) = runs["offline"], runs["nodes"]
    if any(r.failed for r in offline + nodes):
        raise RuntimeError("an episode of the offline benchmark failed")
    steps = sum(r.steps for r in offline)
    keys = {
        "offline_sphere_test_s": offline_s,
        "nodes_sphere_test_s": nodes_s,
        "offline_period_us": round(offline_s / steps * 1e6, 1),
        "nodes_period_us": round(nodes_s / sum(r.steps for r in nodes) * 1e6, 1),
        "nodes_over_offline": round(nodes_s / offline_s, 3),
    }
    for path, (wall_s, records, parts) in runs.items():
        keys.update(loop_keys(path, wall_s, sum(r.steps for r in records), parts))
    floor = keys["offline_physics_us"] + keys["offline_tick_us"]
    keys["offline_over_floor"] = round(keys["offline_loop_period_us"] / floor, 3)
    return keys
