"""tric-analyze: the paper's analyses of a trained TRIC model, as PNGs (Fig. 12, 13, 14a, 14b, 15,
16 and 17a-c).

    tric-analyze MODEL BAGS... [--out DIR] [--top N] [--feature-rank N] [--robot ROBOT]

Writes the figures of tric_learning.analysis into DIR for the demonstrations in BAGS (bags or
folders of bags, the training ones or others of the same feature definition), and, for a model
chosen among candidates (tric-train), selection.png: each candidate's score against its rollouts'
outcomes. Prints the share of demonstration steps along which f decreases, the mean cosine, the
top features and how the model was chosen. --robot: the robot of the model and the bags (a shipped
profile's name or a profile file, docs/robots.md; default tric_arm_hand). Exit status 0, or 2 with
one line on stderr when the model or a bag is refused.
"""

import argparse
import pathlib
import sys

# Only what the arguments need: --help and argument errors answer before torch, pinocchio and
# matplotlib are imported (run imports the analyses once the arguments are checked).
from tric_sim.tools.claims import claim
from tric_sim.tools.interrupts import run_interruptible
from tric_sim.tools.output_files import check_output_folder
from tric_sim.tools.robot_option import add_robot_option, checked_robot

PROG = "tric-analyze"


def main(argv=None) -> int:
    return run_interruptible("tric-analyze", run, argv, "")


def run(argv) -> int:
    parser = argparse.ArgumentParser(prog=PROG, description=__doc__.splitlines()[0])
    parser.add_argument("model", metavar="MODEL", help="a TRIC model file (.safetensors)")
    parser.add_argument("bags", nargs="+", metavar="BAGS", help="MCAP bags, or folders of them")
    parser.add_argument(
        "--out", default="analysis", metavar="DIR", help="folder for the PNGs (default: analysis)"
    )
    parser.add_argument(
        "--top",
        type=int,
        default=20,
        help="features named in Fig. 16 and shown in Fig. 17a (default %(default)s)",
    )
    parser.add_argument(
        "--feature-rank",
        type=int,
        metavar="N",
        help="the feature of Fig. 17b/c: the N-th by score (default: the paper's, "
        "tric_learning.analysis.DEFAULT_FEATURE_RANK)",
    )
    add_robot_option(parser)
    args = parser.parse_args(argv)
    try:
        args.robot = checked_robot(args).spec
        if args.top < 1:
            raise ValueError("--top must be at least 1")
        if args.feature_rank is not None and args.feature_rank < 1:
            raise ValueError("--feature-rank must be at least 1")
        check_output_folder(args.out, "--out folder")
        held = claim(args.out, "--out folder", folder=True)
    except ValueError as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    with held:
        return analyze(args)


def analyze(args) -> int:
    """Measure the model on the bags, write the figures into --out and print the numbers; the
    exit status."""
    try:
        from tric_learning.analysis import (
            DEFAULT_FEATURE_RANK,
            FALLING_STEP,
            MOVING_STEP,
            SELECTION_FIGURE,
            SLOW_STEPS,
            WEIGHT_SHARE,
            key_numbers,
            plot_selection,
            ranked_feature,
            write_figures,
        )
        from tric_learning.analysis.attraction import (
            ROLLOUTS,
            SIGMA,
            TICKS,
            attraction_numbers,
            end_measures,
            rollouts_from_demo_ends,
        )
        from tric_learning.bags.loader import load_dataset
        from tric_learning.model_file import ModelFile, value_function
        from tric_sim.world.robot_model import RobotModel

        rank = DEFAULT_FEATURE_RANK if args.feature_rank is None else args.feature_rank
        robot = RobotModel(args.robot)
        dataset = load_dataset(args.bags, robot)
        model_file = ModelFile.load(args.model, expected=dataset.definition)
        model = value_function(model_file)
        # refused before any figure
        ranked_feature(model, dataset.definition.feature_names, rank)
        paths = write_figures(model, dataset, pathlib.Path(args.out), args.top, rank, robot)
        selection = model_file.info.get("selection")
        if selection is not None:
            paths.append(plot_selection(selection, pathlib.Path(args.out) / SELECTION_FIGURE))
    except (ValueError, OSError) as error:
        print(f"{PROG}: {error}", file=sys.stderr)
        return 2
    numbers = key_numbers(model, dataset, args.top)
    print(
        f"over every step of {numbers['demos']} demonstrations: mean cosine of grad_q (f o phi) "
        f"and the step {numbers['cosine_weighted']:.3f} weighted by |dq| "
        f"({numbers['cosine_moving']:.3f} over the steps > {MOVING_STEP} rad, "
        f"{numbers['cosine_slow']:.3f} over the {numbers['slow_steps']} steps of "
        f"{SLOW_STEPS[0]} to {SLOW_STEPS[1]} rad); f falls on {numbers['falls']:.1%} of the "
        f"steps >= {FALLING_STEP} rad ({numbers['falls_moving']:.1%} of those > {MOVING_STEP} rad)"
    )
    print(
        f"features: {numbers['features_95']} carry {WEIGHT_SHARE:.0%} of the score; "
        f"{numbers['selected_features']} of {numbers['kept_features']} kept score above 1% of "
        "the largest"
    )
    rollouts = rollouts_from_demo_ends(
        model, dataset, robot, model_file.info["delta"], model_file.info["rho"]
    )
    attracted = attraction_numbers(rollouts)
    print(
        f"Prop. 2: of {attracted['rollouts']} rollouts of the prior-free step from states around "
        f"the demonstrations' ends ({ROLLOUTS} per demo, {SIGMA} rad per joint), "
        f"{attracted['came_back']:.0%} came back to rest nearer y_T, "
        f"{attracted['at_rest']:.0%} came to rest within {TICKS} ticks; they went below f(y_T) "
        f"by {attracted['undershoot_median']:.3f} of the demos' fall (median; at most "
        f"{attracted['undershoot_max']:.3f})"
    )
    ends = end_measures(model, dataset, robot)
    print(
        f"the demonstrations' ends: f above f(y_T) at {ends['end_samples_above']:.0%} of the noisy "
        f"samples around q_T; |grad_q f| at y_T {ends['end_gradient_ratio']:.2f} times its median "
        "along the demonstration (a minimum: every sample above, a gradient near 0)"
    )
    print(
        "top features: "
        + ", ".join(f"{t['name']} {t['score']:.3g}" for t in numbers["top_features"][:5])
    )
    if selection is not None:
        config = selection["config"]
        print(
            f"chosen: seed {', '.join(map(str, selection['chosen']))} of "
            f"{len(selection['candidates'])} candidates from group {selection['group_seed']} by "
            f"the score '{config['score']}' ("
            + ", ".join(
                f"s{row['seed']} "
                + ("failed" if row["score"] is None else format(row["score"], ".3g"))
                for row in selection["candidates"]
            )
            + ")"
        )
    print(f"wrote {', '.join(str(path) for path in paths)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
