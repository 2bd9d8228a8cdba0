"""tric-record: record teacher demonstrations to MCAP bags, through the real nodes.

    tric-record DATASET|--situations-file FILE [--out DIR] [--overwrite] [--period S] [--duration S]
                [--domain-id N] [--robot ROBOT] [--viz [--viz-port P]]

Runs the simulator (lockstep), the teacher and the recorder nodes in one process: for each situation
the teacher demonstrates (action /teacher/demonstrate) and the recorder writes one bag
DIR/<situation>.mcap. DATASET is a built-in data set (sphere_train, cylinder_train, box_train, ...),
in the robot's workspace (its profile's; docs/robots.md).
DIR must be new or empty unless --overwrite is given (then a bag of the same name is replaced).
Before the first demonstration DIR is claimed for this run (another run naming it is refused, naming
this one's PID), its room checked for the bags (which grow with --duration, at most 120 s, and
shrink with --period), and every bag's name: no two situations may map to one file (as DIR's file
system compares names), and no bag may be an input (the situations file). Prints a table of the
demonstrations' outcomes; exits non-zero if any failed. --viz serves a live Foxglove view of the run
(tric_sim.visualizer_node) on ws://127.0.0.1:P (default 8765). --robot: the robot, a shipped
profile's name or a profile file (docs/robots.md; default tric_arm_hand).
"""

import argparse
import contextlib
import pathlib
import sys
import time

# Only what the arguments need: --help and argument errors answer before pybullet, pinocchio and
# rclpy are imported (main imports the nodes once the arguments are checked).
from tric_sim.ros.dds_domains import MAX_DOMAIN_ID, private_domain_id
from tric_sim.tools.claims import claim
from tric_sim.tools.file_names import check_file_names, safe_stem
from tric_sim.tools.interrupts import run_interruptible
from tric_sim.tools.output_files import check_output_folder
from tric_sim.tools.robot_option import add_robot_option, checked_robot
from tric_sim.viz.view_options import add_view_arguments, open_view
from tric_sim.world.durations import DEFAULT_DURATION, MAX_DURATION
from tric_sim.world.situation_files import load_situations
from tric_sim.world.situations import DATASETS, dataset

#: The room a demonstration's bag takes at most, bytes: BAG_BYTES + BAG_BYTES_PER_S per simulated
#: second (the states of every control period, the scene's topics) + BAG_BYTES_PER_SAMPLE per sample
#: (features and Jacobian). Measured: 0.61 MB for 5 s at 0.125 s (estimate 0.94 MB), 1.16 MB for
#: 10 s, 2.26 MB for 20 s, 4.83 MB for 5 s at 0.01 s (estimate 6.4 MB); a box's 8 s, 0.68 MB.
BAG_BYTES, BAG_BYTES_PER_S, BAG_BYTES_PER_SAMPLE = 150_000, 60_000, 12_000
#: The simulator's control period, s: a sample is taken at most once per period.
CONTROL_PERIOD_S = 0.01
#: The longest sampling period, simulated s.
MAX_PERIOD_S = 10.0


def bag_bytes(task: str, duration: float, period: float) -> int:
    """The room a demonstration's bag takes at most, bytes (duration 0: the task's default)."""
    duration = duration or DEFAULT_DURATION[task]
    samples = duration / max(period, CONTROL_PERIOD_S) + 1
    return int(BAG_BYTES + BAG_BYTES_PER_S * duration + BAG_BYTES_PER_SAMPLE * samples)


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
    add_robot_option(parser)
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
    if not 0 < args.period <= MAX_PERIOD_S:
        parser.error(f"--period must be in (0, {MAX_PERIOD_S:g}] simulated s")
    if not 0 <= args.duration <= MAX_DURATION:
        parser.error(f"--duration must be in [0, {MAX_DURATION:g}] simulated s (0: the default)")
    domain_id = private_domain_id() if args.domain_id is None else args.domain_id
    if not 0 <= domain_id <= MAX_DOMAIN_ID:
        parser.error(f"--domain-id must be in [0, {MAX_DOMAIN_ID}]")
    with contextlib.ExitStack() as claims:
        try:
            profile = checked_robot(args)
            args.robot = profile.spec
            situations = (
                load_situations(args.situations_file)
                if args.situations_file
                else dataset(args.dataset, profile.workspace)
            )
            out = claim_folder(args, situations, claims)
        except ValueError as error:
            full = "not empty" in str(error)
            hint = "; give --overwrite to record into it anyway" if full else ""
            print(f"tric-record: {error}{hint}", file=sys.stderr)
            return 2
        return record(args, situations, out, domain_id)


def claim_folder(args, situations, claims: contextlib.ExitStack) -> pathlib.Path:
    """The --out folder, checked and claimed for this run (tric_sim.tools.claims, held until claims
    closes) before any work: one that can be written, empty unless --overwrite, with room for the
    bags (bag_bytes), and a bag name for each situation that no other situation's maps to and
    that is not an input (tric_sim.tools.file_names); ValueError naming the problem."""
    from tric_learning.bags import BAG_SUFFIX

    out = check_output_folder(args.out, "--out")
    claims.enter_context(claim(out, "--out folder", folder=True))
    check_output_folder(
        out,
        "--out",
        must_be_empty=not args.overwrite,
        expected_bytes=sum(bag_bytes(s.task, args.duration, args.period) for s in situations),
    )
    bags = {situation.name: safe_stem(situation.name) + BAG_SUFFIX for situation in situations}
    check_file_names(out, bags, "bag", inputs=(args.situations_file,))
    return out


def record(args, situations, out: pathlib.Path, domain_id: int) -> int:
    """Record the demonstrations into out and print their table; the exit status."""
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
            robot=args.robot,
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
