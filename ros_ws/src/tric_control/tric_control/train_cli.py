"""tric-train: train a TRIC value function (or a DPL baseline policy) from demonstration bags into
a model file.

    tric-train BAGS... [--kind {tric,dpl_joint,dpl_finger}] [--out MODEL] [--hidden-units K]
               [--noisy-samples M] [--sigma RAD] [--alpha-n A] [--alpha-g A] [--alpha-w A] [--l2 W]
               [--iterations N] [--correlation-threshold C] [--seed S] [--include-failed]
               [--tolerant] [--overwrite]

BAGS are MCAP bags written by tric-record or the recorder node, or folders of them. MODEL defaults
to model.safetensors next to the first bag, and must not exist unless --overwrite; it is claimed
for this run before any work (another run naming it is refused, naming this one's PID), its room
checked before the training, and a model file that appears there meanwhile is replaced only with
--overwrite (else the model goes beside it, as MODEL's stem + .new). The hyper-parameters default
to the paper's (Sec. 5.2) but where docs/fidelity.md says.
--kind dpl_joint / dpl_finger trains the DPL baseline instead (tric_learning.training.dpl, Sec.
5.3.2): it takes --hidden-units, --l2, --iterations, --correlation-threshold and --seed; the other
hyper-parameters are TRIC's and ignored.
Bags whose recorded outcome is a failure are refused unless --include-failed; damaged and unfinished
(.part) bags unless --tolerant, which reads them up to their damage (a folder's .part files are
skipped without it). Every bag skipped, read tolerantly or included despite its outcome is named.
Shows the progress of loading, sampling and optimization (with the loss terms), then a summary.
Exit status 0 on success, 2 when a bag, value or path is refused (one line on stderr, nothing
written), 130 when interrupted.
"""

import argparse
import functools
import sys
from collections.abc import Callable

from tqdm import tqdm

# Only what the arguments need: --help and argument errors answer before torch, pybullet,
# pinocchio and rclpy are imported (main imports them once the arguments are checked).
from tric_learning.training.hyperparameters import DPL_KINDS, KINDS, DplConfig, TrainingConfig
from tric_sim.tools.interrupts import run_interruptible

PROG = "tric-train"


class StageBars:
    """progress(stage, fraction, losses) for train_from_bags as one tqdm bar per stage: bags loaded,
    demos sampled, optimizer iterations (with the current loss terms), of every ensemble member
    (members) one after the other."""

    def __init__(self, bags: int, max_iterations: int, enabled: bool = True, members: int = 1):
        self.totals = {
            "loading": (bags, "bag"),
            "sampling": (bags * members, "demo"),
            "optimizing": (max_iterations * members, "it"),
        }
        self.enabled = enabled
        self.stage: str | None = None
        self.bar: tqdm | None = None

    def __call__(self, stage: str, fraction: float, losses):
        if stage != self.stage:
            self.close()
            self.stage = stage
            if stage in self.totals:
                total, unit = self.totals[stage]
                self.bar = tqdm(
                    total=total,
                    desc=f"{stage:10s}",
                    unit=unit,
                    disable=not self.enabled,
                    file=sys.stderr,
                )
        if self.bar is None:
            return
        total = self.totals[stage][0]
        done = round(fraction * total)
        self.bar.update(min(done, total) - self.bar.n)
        if stage == "optimizing" and "n" not in losses:  # DPL: one objective
            self.bar.set_postfix_str(f"L {losses['total']:.4f}", refresh=False)
        elif stage == "optimizing":
            self.bar.set_postfix_str(
                f"L {losses['total']:.4f}  L_n {losses['n']:.4f}  L_g {losses['g']:.4f}  "
                f"|w|_1 {losses['w']:.1f}",
                refresh=False,
            )

    def close(self):
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def parse_arguments(argv):
    defaults, dpl_defaults = TrainingConfig(), DplConfig()
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
        metavar="S",
        type=int,
        default=defaults.seed,
        help="seed of the noisy samples and initial weights (default %(default)s)",
    )
    parser.add_argument(
        "--members",
        metavar="N",
        type=int,
        default=defaults.members,
        help="TRIC: value functions trained on noisy samples and initial weights of their own and "
        "averaged into f (default %(default)s)",
    )
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
    return parser.parse_args(argv)


def summary(run) -> str:
    """The lines printed after training."""
    from tric_learning.training.value import SELECTED_FRACTION

    result, model = run.result, run.result.model
    losses = result.losses
    steps = sum(demo.length for demo in run.dataset.demos)
    return "\n".join(
        [
            f"model      {run.path}",
            f"data       {len(run.dataset.demos)} demonstrations, {steps} steps, "
            f"{result.mean_samples_per_step:.1f} noisy samples per step",
            f"losses     total {losses['total']:.4f} = {result.config.alpha_n:g} L_n "
            f"{losses['n']:.4f} + {result.config.alpha_g:g} L_g {losses['g']:.4f} + "
            f"{result.config.alpha_w:g} |w|_1 {losses['w']:.2f} (L_n, L_g per demonstration step)",
            f"features   {model.scaling.size} -> {len(model.scaling.kept)} kept -> "
            f"{result.selected_features} selected (score above {SELECTED_FRACTION:.0%} of the "
            "largest)",
            f"time       sampling {result.sampling_time_s:.2f} s, optimization "
            f"{result.optimization_time_s:.2f} s ({result.iterations} iterations), total "
            f"{result.train_time_s:.2f} s",
            f"controller delta {result.delta:.4g}, rho {result.rho:.4g}",
        ]
    )


def dpl_summary(run) -> str:
    """The lines printed after a DPL training."""
    result, scaling = run.result, run.result.policy.scaling
    steps = sum(demo.length - 1 for demo in run.dataset.demos)
    unit = "rad" if result.kind == "dpl_joint" else "m"
    return "\n".join(
        [
            f"model      {run.path} ({result.kind})",
            f"data       {len(run.dataset.demos)} demonstrations, {steps} steps of "
            f"{result.sample_period_s * 1e3:.0f} ms",
            f"losses     training MSE {result.losses['mse']:.4g} {unit}^2 per output, mean "
            f"|error| {result.losses['mean_abs_error']:.4g} {unit} (targets' RMS "
            f"{result.target_rms:.4g} {unit})",
            f"features   {scaling.size} -> {len(scaling.kept)} kept",
            f"time       optimization {result.optimization_time_s:.2f} s ({result.iterations} "
            "iterations)",
        ]
    )


def main(argv=None) -> int:
    return run_interruptible(PROG, run, argv, "no model written")


def run(argv) -> int:
    args = parse_arguments(argv)
    config: DplConfig | TrainingConfig
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
        )
    else:
        defaults = TrainingConfig()
        config = TrainingConfig(
            hidden_units=defaults.hidden_units if args.hidden_units is None else args.hidden_units,
            noisy_samples=args.noisy_samples,
            sigma=args.sigma,
            alpha_n=args.alpha_n,
            alpha_g=args.alpha_g,
            alpha_w=args.alpha_w,
            max_iterations=defaults.max_iterations if args.iterations is None else args.iterations,
            correlation_threshold=args.correlation_threshold,
            seed=args.seed,
            members=args.members,
        )
    try:
        config.validate()
    except ValueError as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    from tric_learning.bags.loader import bag_paths
    from tric_learning.training.dpl import train_dpl_from_bags
    from tric_learning.training.from_bags import BagTraining, model_output_path
    from tric_learning.training.value import train_from_bags
    from tric_sim.tools.claims import claim
    from tric_sim.world.robot_model import RobotModel

    # config is the DplConfig or the TrainingConfig that job takes
    job: Callable[..., BagTraining] = (
        functools.partial(train_dpl_from_bags, kind=args.kind)
        if args.kind in DPL_KINDS
        else train_from_bags
    )
    try:
        files = bag_paths(args.bags, args.tolerant, notice=lambda _: None)
        path = model_output_path(args.out, files[0], inputs=files, overwrite=args.overwrite)
        bars = StageBars(
            len(files),
            config.max_iterations,
            enabled=not args.quiet,
            members=getattr(config, "members", 1),
        )
        try:
            with claim(path, "the model path"):
                run = job(
                    args.bags,
                    args.out,
                    config,
                    RobotModel(),
                    bars,
                    include_failed=args.include_failed,
                    tolerant=args.tolerant,
                    notice=lambda text: tqdm.write(f"{PROG}: {text}", file=sys.stderr),
                    overwrite=args.overwrite,
                )
        finally:
            bars.close()
    except (ValueError, OSError) as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    print(dpl_summary(run) if args.kind in DPL_KINDS else summary(run))
    return 0


if __name__ == "__main__":
    sys.exit(main())
