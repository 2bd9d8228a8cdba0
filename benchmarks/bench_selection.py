"""Choosing a model (tric_control.selection) on the reference bags, as `tric-train BAGS` does it
with its defaults (the candidates on a local Ray instance, --jobs the CPUs), per task, from a fresh
process: Ray's start, the candidates' trainings and their rollouts from the demonstrations' starts
all counted.

select_<task>_s: its wall time, s (target: <= 180 each, docs/design.md); select_max_s the largest.
select_<task>_train_s, select_<task>_rollout_s: the candidates' training and rollout seconds
summed (CPU seconds of the workers, not wall time), to say what dominates; select_<task>_other_s:
the wall time less their sum over the CPUs that ran them (start-up, loading, the choice, writing).
"""

import os
import pathlib
import subprocess
import sys
import tempfile
import time

from tric_learning.model_file import ModelFile

BAGS = pathlib.Path(__file__).resolve().parent.parent / "bags"
TASKS = ("sphere", "cylinder", "box")


def run() -> dict:
    results = {}
    jobs = os.cpu_count() or 1
    for task in TASKS:
        print(f"[bench] tric-train bags/{task} ...", file=sys.stderr, flush=True)
        with tempfile.TemporaryDirectory() as out:
            model = pathlib.Path(out) / "chosen.safetensors"
            start = time.perf_counter()
            subprocess.run(
                [
                    sys.executable,
                    "-m",
                    "tric_control.train_cli",
                    str(BAGS / task),
                    "--out",
                    str(model),
                    "--quiet",
                ],
                check=True,
                stdout=subprocess.DEVNULL,
                env=dict(os.environ),
            )
            elapsed = time.perf_counter() - start
            rows = ModelFile.load(model).info["selection"]["candidates"]
        train = sum(row["train_s"] for row in rows)
        rollout = sum(row["rollout_s"] for row in rows)
        results[f"select_{task}_s"] = elapsed
        results[f"select_{task}_train_s"] = train
        results[f"select_{task}_rollout_s"] = rollout
        results[f"select_{task}_other_s"] = elapsed - (train + rollout) / min(jobs, len(rows))
        results[f"select_{task}_candidates"] = len(rows)
    results["select_max_s"] = max(results[f"select_{task}_s"] for task in TASKS)
    return results
