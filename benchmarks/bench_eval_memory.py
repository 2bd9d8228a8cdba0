"""Memory over many episodes: 100 consecutive TRIC episodes through one evaluation graph (simulator,
controller and client nodes in this process, as tric-eval runs them), each judged with the lift
test.

eval_rss_growth_mb: the process's resident memory after the last episode minus after the first
  WARMUP episodes (those fill caches: DDS, Pinocchio and coal buffers, the allocator's pools), MB.
  Target (issue 18): < 50 MB.
eval_rss_start_mb / eval_rss_end_mb: the two measurements; eval_episodes: episodes run;
eval_episode_s: mean wall s per episode after the warm-up.
Each episode grasps one of the 15 test spheres (in turn) with a small TRIC model (K = 5, trained on
3 reference demonstrations) for at most EPISODE_STEPS ticks: what is measured is what the graph
keeps per episode, not the grasp.
"""

import gc
import os
import pathlib
import sys
import tempfile
import time

from tric_control.evaluation.graph import Evaluator
from tric_learning import model_file
from tric_learning.bags.loader import load_dataset
from tric_learning.training.value import TrainingConfig, train
from tric_sim.ros.dds_domains import private_domain_id
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

BAGS = pathlib.Path(__file__).resolve().parent.parent / "bags" / "sphere"
EPISODES = 100
WARMUP = 10
EPISODE_STEPS = 100


def resident_mb() -> float:
    """This process's resident set size, MB (after a garbage collection)."""
    gc.collect()
    with open("/proc/self/statm") as statm:
        pages = int(statm.read().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 1e6


def run() -> dict:
    robot = RobotModel()
    dataset = load_dataset(sorted(BAGS.glob("*.mcap"))[12:15], robot)
    result = train(
        dataset, robot, TrainingConfig(hidden_units=5, noisy_samples=10, max_iterations=20)
    )
    tests = situations.dataset("sphere_test")
    with tempfile.TemporaryDirectory() as folder:
        path = model_file.from_training(result, dataset).save(
            pathlib.Path(folder) / "model.safetensors"
        )
        evaluator = Evaluator("grasp", str(path), EPISODE_STEPS, private_domain_id())
        try:
            for k in range(EPISODES):
                if k == WARMUP:
                    start_mb, started = resident_mb(), time.perf_counter()
                record = evaluator.run(tests[k % len(tests)])
                if record.failed:
                    raise RuntimeError(
                        f"episode {k} on {record.situation} could not run: {record.message}"
                    )
                if (k + 1) % 20 == 0:
                    print(
                        f"[bench] {k + 1} episodes, {resident_mb():.0f} MB resident",
                        file=sys.stderr,
                        flush=True,
                    )
            seconds = time.perf_counter() - started
            end_mb = resident_mb()
        finally:
            evaluator.close()
    return {
        "eval_rss_growth_mb": end_mb - start_mb,
        "eval_rss_start_mb": start_mb,
        "eval_rss_end_mb": end_mb,
        "eval_episodes": EPISODES,
        "eval_episode_s": seconds / (EPISODES - WARMUP),
    }
