"""Training and recording benchmarks on the reference data.

train_default_s: TRIC with the paper's defaults (K = 30, N = 27, M = 60, 100 L-BFGS iterations) on
  bags/sphere, noisy-sample generation included; split into train_default_sampling_s and
  train_default_optimization_s. Target (docs/design.md): <= 10 s on a 2-core machine.
train_linear_s: the same with K = 0 (the linear model), also split.
record_demo_s: one 5 s sphere demonstration recorded through the real nodes in lockstep (simulator,
  teacher, recorder in one process), wall s.
Loading the bags is not counted (bags_load_s says what it costs).
"""

import pathlib
import sys
import tempfile
import time

from tric_learning.bags.loader import load_dataset
from tric_learning.demonstrations import demonstrate_all
from tric_learning.training.value import TrainingConfig, train
from tric_sim.ros.dds_domains import private_domain_id
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

BAGS = pathlib.Path(__file__).resolve().parent.parent / "bags" / "sphere"


def run() -> dict:
    robot = RobotModel()
    start = time.perf_counter()
    dataset = load_dataset([BAGS], robot)
    results = {"bags_load_s": time.perf_counter() - start}
    for name, hidden in (("default", 30), ("linear", 0)):
        print(
            f"[bench] training K = {hidden} on {len(dataset.demos)} demos ...",
            file=sys.stderr,
            flush=True,
        )
        result = train(dataset, robot, TrainingConfig(hidden_units=hidden))
        results[f"train_{name}_s"] = result.train_time_s
        results[f"train_{name}_sampling_s"] = result.sampling_time_s
        results[f"train_{name}_optimization_s"] = result.optimization_time_s
    print("[bench] recording one demonstration ...", file=sys.stderr, flush=True)
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        rows = demonstrate_all(
            situations.sphere_grid()[13:14],
            pathlib.Path(out),
            0.125,
            0.0,
            progress=False,
            domain_id=private_domain_id(),
        )
        results["record_demo_s"] = time.perf_counter() - start
    if not all(result.success and path for _, result, path in rows):
        raise RuntimeError("the benchmark demonstration failed")
    return results
