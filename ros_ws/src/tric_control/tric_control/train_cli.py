"""tric-train: train a TRIC value function (or a DPL baseline policy) from demonstration bags into
a model file, choosing the model among candidates.

    tric-train BAGS... [--kind {tric,dpl_joint,dpl_finger}] [--out MODEL] [--candidates S]
               [--members N] [--score NAME] [--hidden-units K] [--noisy-samples M] [--sigma RAD]
               [--alpha-n A] [--alpha-g A] [--alpha-w A] [--l2 W] [--iterations N]
               [--correlation-threshold C] [--seed G] [--jobs J] [--executor processes|ray]
               [--address HOST:PORT] [--include-failed] [--tolerant] [--overwrite] [--robot ROBOT]

BAGS are MCAP bags written by tric-record or the recorder node, or folders of them. MODEL defaults
to model.safetensors next to the first bag, and must not exist unless --overwrite; it is claimed
for this run before any work (another run naming it is refused, naming this one's PID), its room
checked before the training, and a model file that appears there meanwhile is replaced only with
--overwrite (else the model goes beside it, as MODEL's stem + .new). The hyper-parameters default
to the paper's (Sec. 5.2) but where docs/fidelity.md says.
TRIC trains S candidates with the seeds G, G + 1, ..., G + S - 1 side by side (J at once, on Ray
by default: a local instance, or a cluster at --address), rolls each out from every
demonstration's start situation, ranks them by how closely those rollouts ended where the
demonstrations ended (--score, by default from the demonstrations alone), and keeps the best, or
the best N averaged into one f (tric_control.selection; the defaults:
docs/decisions/model-selection.md). The model file records every candidate.
--kind dpl_joint / dpl_finger trains the DPL baseline instead (tric_learning.training.dpl, Sec.
5.3.2), one model: it takes --hidden-units, --l2, --iterations, --correlation-threshold and
--seed; the other options are TRIC's and ignored.
Bags whose recorded outcome is a failure are refused unless --include-failed; damaged and unfinished
(.part) bags unless --tolerant, which reads them up to their damage (a folder's .part files are
skipped without it). Every bag skipped, read tolerantly or included despite its outcome is named.
Shows the progress of the candidates (DPL: of loading and optimization), then a summary.
--robot: the robot the bags were recorded with (a shipped profile's name or a profile file,
docs/robots.md; default tric_arm_hand); bags of another robot are refused.
Exit status 0 on success, 2 when a bag, value or path is refused (one line on stderr, nothing
written), 130 when interrupted.
"""

import argparse
import os
import sys

from tqdm import tqdm

# Only what the arguments need: --help and argument errors answer before torch, pybullet,
# pinocchio and rclpy are imported (main imports them once the arguments are checked).
from tric_control.evaluation.executors import (
    DEFAULT_EXECUTORS,
    add_executor_arguments,
    chosen_executor,
    open_executor,
)
from tric_control.selection.settings import SCORES, SelectionConfig
from tric_control.train_output import CandidateBar, StageBars, dpl_summary, summary
from tric_learning.training.hyperparameters import DPL_KINDS, KINDS, DplConfig, TrainingConfig
from tric_sim.tools.interrupts import run_interruptible
from tric_sim.tools.robot_option import add_robot_option, checked_robot

PROG = "tric-train"


def parse_arguments(argv):
    defaults, dpl_defaults, selection = TrainingConfig(), DplConfig(), SelectionConfig()
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.split("\n\n")[0])
    parser.add_argument("bags", nargs="+", metavar="BAGS", help="MCAP bags, or folders of them")
    parser.add_argument(
        "--kind",
        choices=KINDS,
        default="tric",
        help="the model: TRIC's value function or a DPL policy (default %(default)s)",
    )
    parser.add_argument(
        "--out",
        default="",
        metavar="MODEL",
        help="model file to write (.safetensors; default: model.safetensors next to the first bag)",
    )
    parser.add_argument(
        "--hidden-units",
        metavar="K",
        type=int,
        help=f"sigmoid units K of f (0: linear model; default {defaults.hidden_units}) "
        f"or of the DPL network (default {dpl_defaults.hidden_units})",
    )
    parser.add_argument(
        "--noisy-samples",
        metavar="M",
        type=int,
        default=defaults.noisy_samples,
        help="noisy samples M per demonstration step (default %(default)s)",
    )
    parser.add_argument(
        "--sigma",
        metavar="RAD",
        type=float,
        default=defaults.sigma,
        help="standard deviation of the noisy samples, rad (default %(default)s)",
    )
    parser.add_argument(
        "--alpha-n",
        metavar="A",
        type=float,
        default=defaults.alpha_n,
        help="weight of L_n (default %(default)s)",
    )
    parser.add_argument(
        "--alpha-g",
        metavar="A",
        type=float,
        default=defaults.alpha_g,
        help="weight of L_g (default %(default)s)",
    )
    parser.add_argument(
        "--alpha-w",
        metavar="A",
        type=float,
        default=defaults.alpha_w,
        help="weight of |w|_1 (default %(default)s)",
    )
    parser.add_argument(
        "--l2",
        metavar="W",
        type=float,
        default=dpl_defaults.l2,
        help="DPL: weight of the L2 penalty on the network's weights (default %(default)s)",
    )
    parser.add_argument(
        "--iterations",
        metavar="N",
        type=int,
        help=f"L-BFGS iterations at most (default {defaults.max_iterations}, "
        f"DPL {dpl_defaults.max_iterations})",
    )
    parser.add_argument(
        "--correlation-threshold",
        metavar="C",
        type=float,
        default=defaults.correlation_threshold,
        help="drop features correlated above this with an earlier one, in (0, 1] (default "
        "%(default)s)",
    )
    parser.add_argument(
        "--seed",
        metavar="G",
        type=int,
        default=defaults.seed,
        help="TRIC: the first candidate's seed G (a seed draws the noisy samples and initial "
        "weights); DPL: the seed of the initial weights (default %(default)s)",
    )
    parser.add_argument(
        "--candidates",
        metavar="S",
        type=int,
        default=selection.candidates,
        help="TRIC: models trained with the seeds G .. G + S - 1 to choose from (default "
        "%(default)s)",
    )
    parser.add_argument(
        "--members",
        metavar="N",
        type=int,
        default=selection.members,
        help="TRIC: the best N candidates kept, averaged into one f (default %(default)s)",
    )
    parser.add_argument(
        "--score",
        choices=SCORES,
        default=selection.score,
        help="TRIC: what ranks the candidates: their rollouts from the demonstrations' starts "
        "against the demonstrations (landmarks, features, joints, value) or, reading the task's "
        "hidden metrics, judge and successes (default %(default)s)",
    )
    parser.add_argument(
        "--jobs",
        metavar="J",
        type=int,
        default=os.cpu_count() or 1,
        help="TRIC: candidates trained at once (default: the number of CPUs)",
    )
    add_executor_arguments(parser, DEFAULT_EXECUTORS["tric-train"])
    parser.add_argument(
        "--include-failed",
        action="store_true",
        help="train on demonstrations whose recorded outcome is a failure too",
    )
    parser.add_argument(
        "--tolerant",
        action="store_true",
        help="read unfinished (.part) and damaged bags up to their damage",
    )
    parser.add_argument(
        "--overwrite", action="store_true", help="replace the model file if it exists"
    )
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    add_robot_option(parser)
    return parser.parse_args(argv)


def main(argv=None) -> int:
    return run_interruptible(PROG, run, argv, "no model written")


def run(argv) -> int:
    args = parse_arguments(argv)
    config: DplConfig | TrainingConfig
    selection = SelectionConfig(args.candidates, args.members, args.score)
    try:
        if args.kind in DPL_KINDS:
            dpl_defaults = DplConfig()
            config = DplConfig(
                hidden_units=dpl_defaults.hidden_units
                if args.hidden_units is None
                else args.hidden_units,
                l2=args.l2,
                correlation_threshold=args.correlation_threshold,
                seed=args.seed,
                max_iterations=dpl_defaults.max_iterations
                if args.iterations is None
                else args.iterations,
            ).validate()
        else:
            defaults = TrainingConfig()
            config = TrainingConfig(
                hidden_units=defaults.hidden_units
                if args.hidden_units is None
                else args.hidden_units,
                noisy_samples=args.noisy_samples,
                sigma=args.sigma,
                alpha_n=args.alpha_n,
                alpha_g=args.alpha_g,
                alpha_w=args.alpha_w,
                max_iterations=defaults.max_iterations
                if args.iterations is None
                else args.iterations,
                correlation_threshold=args.correlation_threshold,
                seed=args.seed,
            ).validate()
            selection.validate()
        if not 1 <= args.jobs <= 64:
            raise ValueError("--jobs must be in [1, 64]")
        robot = checked_robot(args).spec
        choice = chosen_executor(args)
    except ValueError as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    from tric_learning.bags.loader import bag_paths
    from tric_learning.training.from_bags import model_output_path
    from tric_sim.world.robot_model import RobotModel

    notice = lambda text: tqdm.write(f"{PROG}: {text}", file=sys.stderr)  # noqa: E731
    try:
        files = bag_paths(args.bags, args.tolerant, notice=lambda _: None)
        model_output_path(args.out, files[0], inputs=files, overwrite=args.overwrite)
        if isinstance(config, DplConfig):
            from tric_learning.training.dpl import train_dpl_from_bags

            bars = StageBars(len(files), config.max_iterations, enabled=not args.quiet)
            try:
                trained = train_dpl_from_bags(
                    args.bags,
                    args.out,
                    config,
                    RobotModel(robot),
                    bars,
                    kind=args.kind,
                    include_failed=args.include_failed,
                    tolerant=args.tolerant,
                    notice=notice,
                    overwrite=args.overwrite,
                )
            finally:
                bars.close()
            print(dpl_summary(trained))
            return 0
        from tric_control.selection.select_model import select_from_bags

        bar = CandidateBar(selection.candidates, enabled=not args.quiet)
        try:
            with open_executor(choice, num_cpus=args.jobs) as executor:
                chosen = select_from_bags(
                    args.bags,
                    args.out,
                    config,
                    selection,
                    RobotModel(robot),
                    executor,
                    args.jobs,
                    bar,
                    include_failed=args.include_failed,
                    tolerant=args.tolerant,
                    notice=notice,
                    overwrite=args.overwrite,
                )
        finally:
            bar.close()
    except (ValueError, OSError, RuntimeError, ConnectionError) as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    print(summary(chosen))
    return 0


if __name__ == "__main__":
    sys.exit(main())
