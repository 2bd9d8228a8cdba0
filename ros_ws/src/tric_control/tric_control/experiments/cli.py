"""tric-experiments: the paper's experiments, each one command, through the real nodes.

    tric-experiments [NAME ...] [--out DIR] [--situations N] [--jobs N] [--executor processes|ray]
                     [--address HOST:PORT] [--check | --check-only] [--report-only]
                     [--results-page FILE [--beside DIR ...]] [--robot ROBOT]

NAME (default: all, in this order):
  table1    spheres: the teacher and TRIC (K = 30) on the 15 sphere test situations (paper Table 1).
  fig8      TRIC's grasp cost on the first 10 sphere test situations against the noisy samples M
            (5, 20, 60 at N = 27) and the training demonstrations N (3, 9, 27 at M = 60, a seeded
            subset of bags/sphere), for the losses alpha_n L_n + alpha_g L_g with (alpha_n, alpha_g)
            = (1, a), (1, 0), (0, a), a the default alpha_g (paper Fig. 8): 15 models.
  table2    DPL's training and test errors |u - pi(y)| per joint (rad), beside |u| (paper Table 2);
            the test set is the 15 sphere test situations demonstrated by the teacher.
  fig9      TRIC and DPL grasp cost on the training situations with the sphere moved by Gaussian
            noise of 0, 2 and 4 cm per axis (paper Fig. 9; --situations each, default 30).
  table3    cylinders: the teacher, TRIC K = 0 and TRIC K = 30 (paper Table 3).
  exp4      the sphere model facing an obstacle in the approach path, never seen in training.
  table4    boxes opened out of 25: TRIC, DPL in joint space, DPL in finger space, the teacher.
  exp5      stability (ours): 10 sphere test situations pushed (0.1, 0.2, 0.4 rad), with the
            target jumping (2, 5, 10 cm) or drifting (2 cm/s) mid-approach, from random starts
            (0.1, 0.2, 0.4 rad), and 10 test boxes pushed with the finger under the lip: TRIC, DPL
            in joint space (three groups each) and the teacher; success against the perturbation's
            size, and f and the joint speed through a jolt at rest.
  exp5_wide wider situations than the training sets' (box_wide, sphere_wide, cylinder_wide): the
            models of Tables 1, 3, 4 and DPL (three groups each) and the teacher; success against
            the distance from the training range.
  analysis  the sphere, cylinder and box models on their demonstrations (paper Fig. 12-17), three
            seeds each: f along every demo, the cosines of L_g, the collision prior, kernel PCA,
            the feature scores and the mean gradients df/dy by step.

Models are trained on the robot's reference bags (kept in DIR/models and re-used when present):
bags/<set> for the paper's robot, bags/ROBOT/<set> for another (--robot: a shipped profile's name or
a profile file, docs/robots.md; default tric_arm_hand), and run on its data sets, in its workspace.
Every evaluation's episodes are kept in DIR/episodes, keyed on the model file, the situations, the
step budget and the code of the nodes: a rerun re-uses a complete evaluation and runs only the
episodes an interrupted one had not judged; a changed key re-uses nothing.
Every evaluation runs --jobs (default: the number of CPUs) graphs of simulator, teacher and
controller nodes at once, each in a process and DDS domain of its own
(tric_control.evaluation.graph): spawned processes here, or Ray actors (--executor ray: a local
instance; --address or RAY_ADDRESS: a cluster whose machines have the project's environment), where
the trainings then run as Ray tasks; models and results come back to DIR.
DIR is claimed for the run before any work (another run naming it is refused, naming this one's PID;
--check-only only reads it). Each experiment writes DIR/<name>.json and its PNG(s) and prints its
table and a discussion composed from its numbers; DIR/REPORT.md is then rewritten from every
experiment's JSON found in DIR, each table beside the paper's numbers and followed by its
discussion, and the results page (default DIR/results.md; --results-page FILE: elsewhere, its
figures linked relative to it): each experiment's discussion, the paper's numbers and its figures,
then the same for each results folder --beside names (another robot's, each a section of its own).
Each experiment's JSON names the robot.
An experiment that fails (a ValueError or RuntimeError) is named on stderr and the others still
run; the run then exits 2 after writing the report.
--check then compares every experiment's results found in DIR with the design's targets, each for
every group (tric_control.experiments.checks), prints them and exits 1 if one is missed;
--check-only does that without running anything; --report-only rewrites the report and the results
page from the folder's JSON without running anything.
"""

import argparse
import json
import os
import pathlib
import sys
import time

# Only what the arguments need: --help and argument errors answer before torch, pybullet,
# pinocchio, rclpy and matplotlib are imported (run_experiments and check_folder import the rest).
from tric_control.evaluation.executors import (
    DEFAULT_EXECUTORS,
    add_executor_arguments,
    chosen_executor,
    open_executor,
)
from tric_control.experiments import EXPERIMENT_MODULES, experiment
from tric_sim.tools.claims import claim
from tric_sim.tools.interrupts import run_interruptible
from tric_sim.tools.output_files import WriteFailed, atomic_path, check_output_folder
from tric_sim.tools.robot_option import add_robot_option, checked_robot


def main(argv=None) -> int:
    return run_interruptible(
        "tric-experiments",
        run,
        argv,
        "the experiments finished and the episodes judged so far kept (a rerun continues)",
    )


def run(argv) -> int:
    parser = argparse.ArgumentParser(prog="tric-experiments", description=__doc__.splitlines()[0])
    parser.add_argument(
        "names",
        nargs="*",
        metavar="NAME",
        help=f"experiments to run (default: all of {', '.join(EXPERIMENT_MODULES)})",
    )
    parser.add_argument(
        "--out",
        default="results",
        help="results folder (default: results); its models/ and episodes/ are re-used: a model or "
        "an evaluation made as asked is not made again, and a rerun after an interrupt runs only "
        "the episodes not yet judged",
    )
    parser.add_argument(
        "--situations", type=int, default=30, help="situations per shift in fig9 (default 30)"
    )
    parser.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="evaluation graphs run at once, each in a process of its own (default: the CPUs, "
        "%(default)s)",
    )
    add_executor_arguments(parser, DEFAULT_EXECUTORS["tric-experiments"])
    add_robot_option(parser)
    parser.add_argument(
        "--check",
        action="store_true",
        help="after the runs, compare every experiment's results in the folder with the design's "
        "targets (for every group); exit 1 if one is missed",
    )
    parser.add_argument(
        "--check-only", action="store_true", help="--check the folder's results, run nothing"
    )
    parser.add_argument(
        "--report-only",
        action="store_true",
        help="rewrite the folder's REPORT.md and the results page from its JSON, run nothing",
    )
    parser.add_argument(
        "--results-page",
        metavar="FILE",
        help="write the results page here (default: DIR/results.md)",
    )
    parser.add_argument(
        "--beside",
        nargs="+",
        default=[],
        metavar="DIR",
        help="other robots' results folders, each a section of the results page",
    )
    args = parser.parse_args(argv)
    if not 1 <= args.situations <= 300:
        parser.error("--situations must be in [1, 300]")
    if not 1 <= args.jobs <= 64:
        parser.error("--jobs must be in [1, 64]")
    unknown = [name for name in args.names if name not in EXPERIMENT_MODULES]
    if unknown:
        parser.error(
            f"unknown experiment(s) {', '.join(unknown)} (known: {', '.join(EXPERIMENT_MODULES)})"
        )
    missing = [folder for folder in args.beside if not pathlib.Path(folder, "REPORT.md").is_file()]
    if missing:
        parser.error(f"--beside takes results folders (with a REPORT.md): not {', '.join(missing)}")
    try:
        args.executor = chosen_executor(args)
        args.robot = checked_robot(args).spec
        out = check_output_folder(args.out, "--out folder")
    except ValueError as error:
        print(f"tric-experiments: {error}", file=sys.stderr)
        return 2
    page = pathlib.Path(args.results_page) if args.results_page else out / "results.md"
    if args.check_only and not args.report_only:
        return check_folder(out)
    try:
        with claim(out, "--out folder", folder=True):
            if args.report_only:
                write_pages(out, page, args.beside)
                return check_folder(out) if args.check_only else 0
            return run_experiments(args, out, page)
    except (ValueError, WriteFailed, ConnectionError) as error:
        print(f"tric-experiments: {error}", file=sys.stderr)
        return 2


def write_pages(out, page, beside=()) -> None:
    """Rewrite out/REPORT.md and the results page from the experiments' JSON in out (and in each
    results folder beside)."""
    from tric_control.experiments.report import write_report, write_results_page

    folders = tuple(pathlib.Path(folder) for folder in beside)
    print(f"wrote {write_report(out)} and {write_results_page(out, page, folders)}")


def run_experiments(args, out, page) -> int:
    """Run the experiments args names into out; the exit status."""
    import matplotlib

    matplotlib.use("Agg")
    from tric_control.experiments.runner import Runner

    with open_executor(args.executor, num_cpus=args.jobs) as executor:
        return _run_each(args, out, page, Runner(out, args.jobs, executor, args.robot))


def _run_each(args, out, page, runner) -> int:
    """Run the experiments args names with runner into out, then write the report and the results
    page; the exit status (2 when an experiment failed: the others still ran and were kept)."""
    import matplotlib.pyplot as plt

    from tric_control.evaluation.records import write_json

    failed = []
    for name in args.names or list(EXPERIMENT_MODULES):
        print(f"\n=== {name}: {experiment(name).TITLE}", flush=True)
        started = time.monotonic()
        try:
            options = {"count": args.situations} if name == "fig9" else {}
            result = experiment(name).run(runner, **options)
        except (ValueError, RuntimeError) as error:
            print(f"tric-experiments: {name}: {error}", file=sys.stderr, flush=True)
            failed.append(name)
            continue
        # one matplotlib figure, for out/<name>.png; else the experiment wrote its "figures"
        if "figure" in result:
            result["figure"].tight_layout()
            with atomic_path(out / f"{name}.png") as temporary:
                result["figure"].savefig(temporary, dpi=110)
            plt.close(result.pop("figure"))
        result.update(
            date=time.strftime("%Y-%m-%d %H:%M"),
            wall_s=time.monotonic() - started,
            robot=runner.profile.name,
        )
        write_json(out / f"{name}.json", result)
        print(result["table"])
        print(f"paper: {result['paper']}")
        print(f"discussion: {result['discussion']}")
        print(f"({name}: {result['wall_s']:.0f} s)", flush=True)
    write_pages(out, page, args.beside)
    if failed:
        print(f"tric-experiments: failed: {', '.join(failed)}", file=sys.stderr)
        return 2
    return check_folder(out) if args.check else 0


def check_folder(out) -> int:
    """Print the checks of the experiments' results in out; 0 if every target is met, 1 if one is
    missed, 2 if out holds no result with a target."""
    from tric_control.experiments.checks import check_results, check_table

    results = {
        name: json.loads((out / f"{name}.json").read_text())
        for name in EXPERIMENT_MODULES
        if (out / f"{name}.json").is_file()
    }
    checks = check_results(results)
    if not checks:
        print(f"tric-experiments: {out} holds no results with targets", file=sys.stderr)
        return 2
    print(f"\nthe design's targets, each for every group:\n{check_table(checks)}")
    return 0 if all(check.met for check in checks) else 1


if __name__ == "__main__":
    sys.exit(main())
