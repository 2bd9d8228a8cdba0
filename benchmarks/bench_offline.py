"""Offline evaluation against the nodes.

nodes_over_offline: the wall time of a TRIC model on the 15 sphere_test situations through the
  nodes (tric-eval: simulator, controller and client in one process, lockstep, one graph), divided
  by the same episodes offline (tric-eval --offline: the controller core on PhysicsWorld, one
  process). Target (docs/design.md): at most 1.5. offline_sphere_test_s and nodes_sphere_test_s
  give both times; offline_period_us and nodes_period_us the wall time per control period (the
  episodes' ticks summed), which benchmarks/run.py sets against the physics and the tick
  (offline_over_floor).
Training the model (the paper's defaults on bags/sphere) is not counted.
"""

import pathlib
import sys
import tempfile
import time

from tric_control.evaluation.graph import evaluate
from tric_control.evaluation.offline import evaluate_offline
from tric_learning.training.value import TrainingConfig, train_from_bags
from tric_sim.ros.dds_domains import private_domain_id
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

BAGS = pathlib.Path(__file__).resolve().parent.parent / "bags" / "sphere"


def run() -> dict:
    tests = situations.dataset("sphere_test")
    with tempfile.TemporaryDirectory() as folder:
        print("[bench] training the sphere model ...", file=sys.stderr, flush=True)
        model = train_from_bags(
            [BAGS], pathlib.Path(folder) / "sphere.safetensors", TrainingConfig(), RobotModel()
        ).path
        start = time.perf_counter()
        offline = evaluate_offline(tests, str(model), progress=False)
        offline_s = time.perf_counter() - start
        start = time.perf_counter()
        nodes = evaluate(tests, model, progress=False, domain_id=private_domain_id())
        nodes_s = time.perf_counter() - start
    if any(r.failed for r in offline + nodes):
        raise RuntimeError("an episode of the offline benchmark failed")
    return {
        "offline_sphere_test_s": offline_s,
        "nodes_sphere_test_s": nodes_s,
        "offline_period_us": round(offline_s / sum(r.steps for r in offline) * 1e6, 1),
        "nodes_period_us": round(nodes_s / sum(r.steps for r in nodes) * 1e6, 1),
        "nodes_over_offline": round(nodes_s / offline_s, 3),
    }
