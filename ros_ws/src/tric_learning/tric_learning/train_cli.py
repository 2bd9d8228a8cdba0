"""tric-train: train a TRIC value function from demonstration bags into a model file.

    tric-train BAGS... [--out MODEL] [--hidden-units K] [--noisy-samples M] [--sigma RAD]
               [--alpha-n A] [--alpha-g A] [--alpha-w A] [--iterations N]
               [--correlation-threshold C] [--seed S]

BAGS are MCAP bags written by tric-record or the recorder node, or folders of them. MODEL defaults to
model.safetensors next to the first bag; the hyper-parameters default to the paper's (Sec. 5.2).
Shows the progress of loading, sampling and optimization (with the loss terms), then a summary.
Exit status 0 on success, 2 when a bag, value or path is refused (one line on stderr, nothing
written), 130 when interrupted.
"""

import argparse
import sys

from tqdm import tqdm

from tric_learning.recording import bag_paths
from tric_learning.training import SELECTED_FRACTION, TrainingConfig, train_from_bags
from tric_sim.robot_model import RobotModel

PROG = "tric-train"


class StageBars:
    """progress(stage, fraction, losses) for train_from_bags as one tqdm bar per stage: bags loaded,
    demos sampled, optimizer iterations (with the current loss terms)."""

    def __init__(self, bags: int, max_iterations: int, enabled: bool = True):
        self.totals = {"loading": (bags, "bag"), "sampling": (bags, "demo"), "optimizing": (max_iterations, "it")}
        self.enabled = enabled
        self.stage, self.bar = None, None

    def __call__(self, stage: str, fraction: float, losses):
        if stage != self.stage:
            self.close()
            self.stage = stage
            if stage in self.totals:
                total, unit = self.totals[stage]
                self.bar = tqdm(total=total, desc=f"{stage:10s}", unit=unit, disable=not self.enabled,
                                file=sys.stderr)
        if self.bar is None:
            return
        total = self.totals[stage][0]
        done = losses["iteration"] if stage == "optimizing" else round(fraction * total)
        self.bar.update(min(done, total) - self.bar.n)
        if stage == "optimizing":
            self.bar.set_postfix_str(f"L {losses['total']:.4f}  L_n {losses['n']:.4f}  L_g {losses['g']:.4f}  "
                                     f"|w|_1 {losses['w']:.1f}", refresh=False)

    def close(self):
        if self.bar is not None:
            self.bar.close()
            self.bar = None


def parse_arguments(argv):
    defaults = TrainingConfig()
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    parser.add_argument("bags", nargs="+", metavar="BAGS", help="MCAP bags, or folders of them")
    parser.add_argument("--out", default="", metavar="MODEL",
                        help="model file to write (.safetensors; default: model.safetensors next to the first bag)")
    parser.add_argument("--hidden-units", metavar="K", type=int, default=defaults.hidden_units,
                        help="sigmoid units K of f (0: linear model; default %(default)s)")
    parser.add_argument("--noisy-samples", metavar="M", type=int, default=defaults.noisy_samples,
                        help="noisy samples M per demonstration step (default %(default)s)")
    parser.add_argument("--sigma", metavar="RAD", type=float, default=defaults.sigma,
                        help="standard deviation of the noisy samples, rad (default %(default)s)")
    parser.add_argument("--alpha-n", metavar="A", type=float, default=defaults.alpha_n,
                        help="weight of L_n (default %(default)s)")
    parser.add_argument("--alpha-g", metavar="A", type=float, default=defaults.alpha_g,
                        help="weight of L_g (default %(default)s)")
    parser.add_argument("--alpha-w", metavar="A", type=float, default=defaults.alpha_w,
                        help="weight of |w|_1 (default %(default)s)")
    parser.add_argument("--iterations", metavar="N", type=int, default=defaults.max_iterations,
                        help="L-BFGS iterations at most (default %(default)s)")
    parser.add_argument("--correlation-threshold", metavar="C", type=float, default=defaults.correlation_threshold,
                        help="drop features correlated above this with an earlier one, in (0, 1] (default %(default)s)")
    parser.add_argument("--seed", metavar="S", type=int, default=defaults.seed,
                        help="seed of the noisy samples and initial weights (default %(default)s)")
    parser.add_argument("--quiet", action="store_true", help="no progress bars")
    return parser.parse_args(argv)


def summary(run) -> str:
    """The lines printed after training."""
    result, model = run.result, run.result.model
    losses = result.losses
    steps = sum(demo.length for demo in run.dataset.demos)
    return "\n".join([
        f"model      {run.path}",
        f"data       {len(run.dataset.demos)} demonstrations, {steps} steps, "
        f"{result.mean_samples_per_step:.1f} noisy samples per step",
        f"losses     total {losses['total']:.4f} = {result.config.alpha_n:g} L_n {losses['n']:.4f} "
        f"+ {result.config.alpha_g:g} L_g {losses['g']:.4f} + {result.config.alpha_w:g} |w|_1 {losses['w']:.2f} "
        "(L_n, L_g per demonstration step)",
        f"features   {model.scaling.size} -> {len(model.scaling.kept)} kept -> {result.selected_features} selected "
        f"(score above {SELECTED_FRACTION:.0%} of the largest)",
        f"time       sampling {result.sampling_time_s:.2f} s, optimization {result.optimization_time_s:.2f} s "
        f"({result.iterations} iterations), total {result.train_time_s:.2f} s",
        f"controller delta {result.delta:.4g}, rho {result.rho:.4g}",
    ])


def main(argv=None) -> int:
    args = parse_arguments(argv)
    config = TrainingConfig(hidden_units=args.hidden_units, noisy_samples=args.noisy_samples, sigma=args.sigma,
                            alpha_n=args.alpha_n, alpha_g=args.alpha_g, alpha_w=args.alpha_w,
                            max_iterations=args.iterations, correlation_threshold=args.correlation_threshold,
                            seed=args.seed)
    try:
        config.validate()
        bars = StageBars(len(bag_paths(args.bags)), config.max_iterations, enabled=not args.quiet)
        try:
            run = train_from_bags(args.bags, args.out, config, RobotModel(), bars)
        finally:
            bars.close()
    except (ValueError, OSError) as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{PROG}: interrupted", file=sys.stderr)
        return 130
    print(summary(run))
    return 0


if __name__ == "__main__":
    sys.exit(main())
