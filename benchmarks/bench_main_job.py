"""The main job end to end: `tric-demo` (record 27 demonstrations, train TRIC, evaluate it and the
teacher on 15 test situations) from an empty results folder, as `make demo` runs it.

main_job_s: its wall time, s (target: <= 150 on 2 cores, docs/design.md). main_job_tric_cost_mean,
main_job_teacher_cost_mean: the Table 1 means it printed, so the timing is read beside what it
produced. main_job_<stage>_s: where the time went, from its demo.json (stages_s): recording, the
candidates' training and rollouts and the choice (candidates_and_choice), the teacher's and TRIC's
evaluations, the table and figures; main_job_candidates_training_summed_s and
main_job_candidates_rollouts_summed_s: the candidates' training and rollouts summed over the
processes they ran in.
"""

import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time


def run() -> dict:
    with tempfile.TemporaryDirectory() as out:
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", "tric_control.demo_cli", "--out", out],
            check=True,
            stdout=subprocess.DEVNULL,
            env=dict(os.environ),
        )
        elapsed = time.perf_counter() - start
        summary = json.loads((pathlib.Path(out) / "demo.json").read_text())
    return {
        "main_job_s": elapsed,
        "main_job_tric_cost_mean": summary["tric_cost_mean"],
        "main_job_teacher_cost_mean": summary["teacher_cost_mean"],
        **{f"main_job_{stage}_s": round(s, 1) for stage, s in summary["stages_s"].items()},
    }
