"""`--help` of the tools: the wall time of a fresh interpreter printing each tool's help (median of
three runs per tool), and the slowest of them (docs/design.md section 5: under 0.5 s)."""

import statistics
import subprocess
import sys
import time

#: The command-line tools (their modules).
TOOLS = {
    "tric-eval": "tric_control.evaluate_cli",
    "tric-train": "tric_control.train_cli",
    "tric-record": "tric_learning.record_cli",
    "tric-demo": "tric_control.demo_cli",
    "tric-experiments": "tric_control.experiments.cli",
    "tric-study": "tric_control.study.cli",
    "tric-analyze": "tric_learning.analyze_cli",
    "tric-snapshot": "tric_sim.snapshot",
}
RUNS = 3


def help_seconds(module: str) -> float:
    """The median wall time of `python -m module --help`, s."""
    times = []
    for _ in range(RUNS):
        start = time.perf_counter()
        subprocess.run(
            [sys.executable, "-m", module, "--help"],
            check=True,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def run() -> dict:
    seconds = {name: help_seconds(module) for name, module in TOOLS.items()}
    results = {f"help_{name.removeprefix('tric-')}_s": round(s, 3) for name, s in seconds.items()}
    results["help_max_s"] = max(results.values())
    return results
