"""Run the project's benchmarks and write one JSON object to results/bench.json.

Each module benchmarks/bench_*.py defines `run() -> dict` returning flat {key: number} results (keys
are named in the issues, e.g. "sim_lockstep_rtf"). This runner calls them in name order, merges
their results with a description of the machine, prints the object and writes it. --check then
compares every key that has a target (TARGETS: docs/design.md section 5 and the issues) with it,
prints the comparison and exits 1 if one is missed; --check-only does that for an existing results
file.

    python benchmarks/run.py [--only NAME ...] [--out results/bench.json] [--check | --check-only]
"""

import argparse
import importlib.util
import json
import os
import pathlib
import platform
import sys
import time

from tric_sim.tools.output_files import write_text_atomic

HERE = pathlib.Path(__file__).resolve().parent

#: key -> (at most / at least, bound, where the target comes from).
TARGETS = {
    "train_default_s": ("<=", 15.0, "docs/design.md: training the default model"),
    "controller_tick_p99_ms": ("<=", 0.5, "docs/design.md: one controller tick, p99"),
    "controller_jitter_p99_ms": ("<=", 1.0, "issue 37: the 100 Hz real-time loop's period"),
    "controller_vs_pink": ("<", 1.0, "docs/design.md: tick p50 below pin-pink's solve_ik"),
    "nodes_over_offline": ("<=", 1.5, "docs/design.md: the same episodes, nodes over offline"),
    "offline_over_floor": ("<=", 1.15, "docs/design.md: offline loop over its physics + ticks"),
    "sim_lockstep_overhead": ("<=", 1.6, "docs/design.md: lockstep period over raw physics"),
    "ros_round_trip_over_physics": ("<=", 0.5, "docs/design.md: one message each way"),
    "sim_lockstep_rtf": (">=", 20.0, "the lockstep simulator's real-time factor (an issue)"),
    "main_job_s": ("<=", 150.0, "docs/design.md: the whole main job"),
    "select_max_s": ("<=", 180.0, "docs/design.md: choosing a model, per task"),
    "help_max_s": ("<", 0.5, "docs/design.md: --help of every tool"),
    "features_us": ("<=", 100.0, "phi and dphi/dq of the grasp task (an issue)"),
    "eval_rss_growth_mb": ("<", 50.0, "memory over 100 episodes (an issue)"),
}
COMPARE = {"<=": float.__le__, "<": float.__lt__, ">=": float.__ge__}


#: Keys computed from others measured in the same run: name -> (numerator, denominator keys,
#: summed). sim_lockstep_overhead: the lockstep period through ROS over the raw physics period;
#: ros_round_trip_over_physics: one JointState each way over a raw physics period.
#: (offline_over_floor is measured by bench_offline itself: its parts are timed in the same
#: episodes, since the physics of an episode, contacts included, costs more than a still robot's.)
RATIOS = {
    "sim_lockstep_overhead": ("sim_lockstep_period_us", ("sim_physics_period_us",)),
    "ros_round_trip_over_physics": ("sim_ros_round_trip_us", ("sim_physics_period_us",)),
}


def derived(results: dict) -> dict:
    """The RATIOS whose keys the results hold."""
    ratios = {}
    for name, (numerator, parts) in RATIOS.items():
        if numerator in results and all(part in results for part in parts):
            ratios[name] = round(results[numerator] / sum(results[part] for part in parts), 3)
    return ratios


def check(results: dict) -> int:
    """Print each key with a target against it; 1 if one is missed, 0 otherwise."""
    missed = 0
    for key, (relation, bound, source) in TARGETS.items():
        if key not in results:
            continue
        met = COMPARE[relation](float(results[key]), bound)
        missed += not met
        print(
            f"{'met   ' if met else 'MISSED'} {key:28s} {results[key]:>10.4g} {relation} "
            f"{bound:<8g} {source}"
        )
    return 1 if missed else 0


def machine() -> dict:
    return {
        "machine_cpus": os.cpu_count(),
        "machine_python": platform.python_version(),
        "machine_platform": platform.platform(),
        "bench_date": time.strftime("%Y-%m-%dT%H:%M:%S"),
    }


def load(path: pathlib.Path):
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--only",
        nargs="*",
        default=None,
        help="benchmark module names to run (e.g. bench_sim); default: all",
    )
    parser.add_argument("--out", default="results/bench.json", help="output JSON file")
    parser.add_argument(
        "--check", action="store_true", help="compare the keys with their targets; 1 if one missed"
    )
    parser.add_argument(
        "--check-only", action="store_true", help="--check the --out file, run nothing"
    )
    args = parser.parse_args(argv)
    if args.check_only:
        return check(json.loads(pathlib.Path(args.out).read_text()))
    results = machine()
    modules = sorted(HERE.glob("bench_*.py"))
    if args.only:
        unknown = set(args.only) - {m.stem for m in modules}
        if unknown:
            parser.error(
                f"unknown benchmark(s): {', '.join(sorted(unknown))}; "
                f"available: {', '.join(m.stem for m in modules)}"
            )
        modules = [m for m in modules if m.stem in args.only]
    for path in modules:
        print(f"[bench] {path.stem} ...", file=sys.stderr, flush=True)
        start = time.perf_counter()
        results.update(load(path).run())
        print(f"[bench] {path.stem} done in {time.perf_counter() - start:.1f} s", file=sys.stderr)
    results.update(derived(results))
    text = json.dumps(results, indent=2, sort_keys=True)
    write_text_atomic(args.out, text + "\n")
    print(text)
    return check(results) if args.check else 0


if __name__ == "__main__":
    sys.exit(main())
