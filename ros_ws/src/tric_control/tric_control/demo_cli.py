"""tric-demo: the main job. Record sphere demonstrations, train TRIC, run it against the teacher.

    tric-demo [--reuse [BAGS]] [--out DIR] [--iterations N] [--jobs N] [--check]
              [--robot ROBOT] [--viz [--viz-port P]]

1. Record the paper's 27 sphere-grid demonstrations with the teacher through the real nodes
   (simulator in lockstep, teacher, recorder) into DIR/demo/bags, or, with --reuse, take the bags
   in BAGS (default: the robot's reference set, bags/sphere for the paper's robot, bags/ROBOT/sphere
   for another).
2. Train TRIC's candidates on them with the defaults (K = 30, M = 60, alpha = 1, 30, 0.001: the
   paper's but for alpha_g, see tric_learning.training.value), --jobs at once in spawned processes,
   roll each out from the demonstrations' starts and choose the model (tric_control.selection,
   docs/decisions/model-selection.md).
3. Evaluate the teacher and the learned controller on the 15 test situations (paper Table 1),
   through the simulator, teacher and controller nodes, judged by the hidden metrics; --jobs
   (default: the number of CPUs) graphs of them at once, each in a process of its own.
4. Print the Table 1 comparison; write DIR/demo.json (teacher_cost_mean, tric_cost_mean,
   tric_cost_max, tric_lift_passed, episodes, train_s (the candidates and the choice), total_s; the
   chosen seeds and every candidate's score under "training"; and under "tric" and "teacher"
   each agent's summary and per-episode records),
   DIR/demo.png (grasp costs per test situation) and DIR/demo_grasp.png (one TRIC grasp).

--robot: the robot (a shipped profile's name or a profile file, docs/robots.md; default
tric_arm_hand); the sphere grid and the test spheres are then its workspace's (`make demo
ROBOT=panda` runs the job on the Franka Panda).

--viz serves a live Foxglove view of the whole run (tric_sim.visualizer_node) on ws://127.0.0.1:P
(default 8765); the evaluations then run on one graph (--jobs 1), the one it shows.

The targets (docs/design.md): TRIC's mean grasp cost within 0.03 of the teacher's and every TRIC
grasp below 0.25. They are printed as met or not; --check makes the exit code 1 when one is not met.
"""

import argparse
import os
import sys

# Only what the arguments need: --help and argument errors answer before torch, pybullet,
# pinocchio, rclpy and matplotlib are imported (tric_control.demo, the job, is imported after).
from tric_learning.training.hyperparameters import TrainingConfig
from tric_sim.tools.claims import claim
from tric_sim.tools.interrupts import run_interruptible
from tric_sim.tools.output_files import WriteFailed, check_output_folder
from tric_sim.tools.robot_option import add_robot_option, checked_robot, reference_bags
from tric_sim.viz.view_options import add_view_arguments

#: --reuse without a folder: the robot's reference sphere bags (a marker no folder name can be).
REFERENCE = object()


def main(argv=None) -> int:
    return run_interruptible(
        "tric-demo", run, argv, "the demonstrations recorded so far kept as bags"
    )


def run(argv) -> int:
    parser = argparse.ArgumentParser(prog="tric-demo", description=__doc__.splitlines()[0])
    parser.add_argument(
        "--reuse",
        nargs="?",
        const=REFERENCE,
        default=None,
        metavar="BAGS",
        help="train on recorded bags instead of recording (default: the robot's reference bags)",
    )
    parser.add_argument("--out", default="results", help="results folder (default: results)")
    parser.add_argument(
        "--iterations",
        type=int,
        default=TrainingConfig.max_iterations,
        help="L-BFGS iterations at most (default: TrainingConfig's, %(default)s)",
    )
    parser.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="candidates trained and evaluation graphs run at once (default: the number of CPUs)",
    )
    parser.add_argument("--check", action="store_true", help="exit 1 when TRIC misses its targets")
    add_robot_option(parser)
    add_view_arguments(parser)
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error("--jobs must be at least 1")
    if args.viz and args.jobs > 1:
        print(
            "tric-demo: --viz shows one graph: the evaluations run with --jobs 1", file=sys.stderr
        )
        args.jobs = 1
    try:
        args.profile = checked_robot(args)
        args.robot = args.profile.spec
        if args.reuse is REFERENCE:
            args.reuse = str(reference_bags(args.profile, "sphere"))
        out = check_output_folder(args.out, "--out folder")
        from tric_control.demo import run_demo

        with claim(out, "--out folder", folder=True):
            return run_demo(args, out)
    except (ValueError, RuntimeError, WriteFailed) as error:
        print(f"tric-demo: {error}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
