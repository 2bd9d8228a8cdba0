"""Run the project's benchmarks and write one JSON object to results/bench.json.

Each module benchmarks/bench_*.py defines `run() -> dict` returning flat {key: number} results (keys
are named in the issues, e.g. "sim_lockstep_rtf"). This runner calls them in name order, merges
their results with a description of the machine, prints the object and writes it.

    python benchmarks/run.py [--only NAME ...] [--out results/bench.json]
"""

import argparse
import importlib.util
import json
import os
import pathlib
import platform
import sys
import time

HERE = pathlib.Path(__file__).resolve().parent


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
    args = parser.parse_args(argv)
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
    out = pathlib.Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    text = json.dumps(results, indent=2, sort_keys=True)
    out.write_text(text + "\n")
    print(text)
    return 0


if __name__ == "__main__":
    sys.exit(main())
