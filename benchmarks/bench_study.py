"""A fixed small study, run locally with --jobs 2 from nothing: the default variant on the sphere
and obstacle tasks with seeds 0 and 1 (4 cells: 2 trainings with the defaults, 2 x 15 sphere and
2 x 10 obstacle validation episodes offline), each executor in a fresh interpreter, the wall time
of the whole command (Ray's start included). study_cells_per_hour is tric-study's default
executor's; study_cells_per_hour_processes and study_cells_per_hour_ray each one's."""

import pathlib
import subprocess
import sys
import tempfile
import time

from tric_control.evaluation.executors import DEFAULT_EXECUTORS, EXECUTORS

#: The study's cells: tric-study's arguments but --out and --executor.
STUDY = ["--tasks", "sphere", "obstacle", "--seeds", "0", "1", "--jobs", "2"]
CELLS = 4
ROOT = pathlib.Path(__file__).resolve().parent.parent


def cells_per_hour(executor: str) -> float:
    """CELLS over the wall time of the study run with executor from nothing, per hour."""
    with tempfile.TemporaryDirectory(prefix="bench-study-") as out:
        started = time.perf_counter()
        subprocess.run(
            [
                sys.executable,
                "-m",
                "tric_control.study.cli",
                *STUDY,
                "--executor",
                executor,
                "--out",
                out,
            ],
            check=True,
            cwd=ROOT,  # bags/
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        return CELLS * 3600.0 / (time.perf_counter() - started)


def run() -> dict:
    rates = {executor: round(cells_per_hour(executor), 1) for executor in EXECUTORS}
    return {
        "study_cells_per_hour": rates[DEFAULT_EXECUTORS["tric-study"]],
        **{f"study_cells_per_hour_{executor}": rate for executor, rate in rates.items()},
    }
