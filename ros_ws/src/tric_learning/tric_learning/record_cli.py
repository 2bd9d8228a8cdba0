"""tric-record: record teacher demonstrations to MCAP bags, through the real nodes.

    tric-record DATASET|--situations-file FILE [--out DIR] [--overwrite] [--period S] [--duration S]
                [--domain-id N] [--viz [--viz-port P]]

Runs the simulator (lockstep), the teacher and the recorder nodes in one process: for each situation
the teacher demonstrates (action /teacher/demonstrate) and the recorder writes one bag
DIR/<situation>.mcap. DATASET is a built-in data set (sphere_train, cylinder_train, box_train, ...).
DIR must be new or empty unless --overwrite is given (then a bag of the same name is replaced).
Prints a table of the demonstrations' outcomes; exits non-zero if any failed. --viz serves a live
Foxglove view of the run (tric_sim.visualizer_node) on ws://127.0.0.1:P (default 8765).
"""

import argparse
import sys
import time

# Only what the arguments need: --help and argument errors answer before pybullet, pinocchio and
# rclpy are imported (main imports the nodes once the arguments are checked).
from tric_sim.ros.dds_domains import MAX_DOMAIN_ID, private_domain_id
from tric_sim.tools.interrupts import run_interruptible
from tric_sim.tools.output_files import check_output_folder
from tric_sim.viz.view_options import add_view_arguments, open_view
from tric_sim.world.situation_files import load_situations
from tric_sim.world.situations import DATASETS, dataset

#: The room a demonstration's bag takes at most, bytes (the reference bags: 0.5 to 0.6 MB).
BAG_BYTES_PER_DEMONSTRATION = 10**6


def main(argv=None) -> int:
    return run_interruptible(
        "tric-record", run, argv, "the bags of the finished demonstrations kept"
    )


def run(argv) -> int:
    parser = argparse.ArgumentParser(prog="tric-record", description=__doc__.splitlines()[0])
    parser.add_argument("dataset", nargs="?", choices=sorted(DATASETS), help="a built-in data set")
    parser.add_argument("--situations-file", help="a YAML/JSON situations file instead of DATASET")
    parser.add_argument(
        "--out",
        default="recordings",
        help="folder for the bags, empty or new unless --overwrite (default: recordings)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="record into a folder that holds files already: a bag of the same name is "
        "replaced, other files are kept",
    )
    parser.add_argument("--period", type=float, default=0.125, help="sampling period, simulated s")
    parser.add_argument(
        "--duration",
        type=float,
        default=0.0,
        help="demonstration length, simulated s (default: 5 s grasps, 8 s boxes)",
    )
    parser.add_argument(
        "--domain-id",
        type=int,
        default=None,
        help="DDS domain of the in-process nodes (default: a private one, 1 + pid %% 100, "
        "so that they never mix with another simulator's topics)",
    )
    add_view_arguments(parser)
    args = parser.parse_args(argv)
    if bool(args.dataset) == bool(args.situations_file):
        parser.error("give either DATASET or --situations-file")
    if not args.period > 0 or args.duration < 0:
        parser.error("--period must be positive and --duration not negative")
    try:
        situations = (
            load_situations(args.situations_file) if args.situations_file else dataset(args.dataset)
        )
        out = check_output_folder(
            args.out,
            "--out",
            must_be_empty=not args.overwrite,
            expected_bytes=BAG_BYTES_PER_DEMONSTRATION * len(situations),
        )
    except ValueError as error:
        hint = "; give --overwrite to record into it anyway" if "is not empty" in str(error) else ""
        print(f"tric-record: {error}{hint}", file=sys.stderr)
        return 2
    domain_id = private_domain_id() if args.domain_id is None else args.domain_id
    if not 0 <= domain_id <= MAX_DOMAIN_ID:
        parser.error(f"--domain-id must be in [0, {MAX_DOMAIN_ID}]")
    from tric_learning.demonstrations import demonstrate_all

    print(f"tric-record: nodes in DDS domain {domain_id}", file=sys.stderr)
    try:
        view = open_view(args, "tric-record")
    except ValueError as error:
        print(f"tric-record: {error}", file=sys.stderr)
        return 2
    start = time.monotonic()
    try:
        rows = demonstrate_all(
            situations,
            out,
            args.period,
            args.duration,
            domain_id=domain_id,
            view=view,
            overwrite=args.overwrite,
        )
    finally:
        if view is not None:
            view.close()
    print(
        f"\n{'situation':24s} {'success':>7s} {'grasp cost':>10s} {'lift':>5s} {'lid (rad)':>9s}  "
        "bag"
    )
    for situation, result, path in rows:
        m = result.metrics
        print(
            f"{situation.name:24s} {str(result.success and m.success):>7s} {m.grasp_cost:10.3f} "
            f"{'yes' if m.lift_passed else '-':>5s} {m.lid_angle:9.2f}  {path or result.message}"
        )
    failed = [s.name for s, r, p in rows if not (r.success and r.metrics.success and p)]
    print(
        f"\n{len(rows) - len(failed)} of {len(rows)} demonstrations succeeded and were recorded "
        f"in {time.monotonic() - start:.1f} s"
    )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
