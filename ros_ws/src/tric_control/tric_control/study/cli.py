"""tric-study: compare training variants of TRIC on the training and validation sets, over
independent groups of candidates.

    tric-study [--variant NAME=OPTIONS ...] [--seeds G ...] [--tasks TASK ...] [--every-candidate]
    [--out DIR] [--jobs N] [--executor processes|ray] [--address HOST:PORT] [--robot ROBOT]

A variant is a name and TrainingConfig fields to change from the defaults, e.g.
`--variant balanced=per_step_weights=true,optimizer=lbfgsb,alpha_g=3` (no options: the defaults);
how the model is chosen: candidates (S), members (the best N kept) and score
(tric_control.selection, the training's defaults otherwise); and controller settings: hand_lead
(rad: how far the command may lead the measured hand joints, motion_rate.MAX_HAND_LEAD by
default), grasp_steps and box_steps (the episodes' step budgets), the contact options, fall_pace
(the knee of tric_control.fall_pace.FallPace: the asked fall follows the fall made; 0: the paper's
constant delta), stall_escapes (the walks out of stalls an episode may take:
tric_control.stall_escape; 3 by default, as the node's; 0: none), and
hard_negative_rounds (rounds of training again on the controller's own rollouts in the training
situations: tric_control.study.hard_negatives).
For each variant, group seed G and task, a model is chosen as a training chooses it: S candidates
(seeds G .. G + S - 1) trained on the reference bags of the task, each rolled out from its
demonstrations' starts, the best kept. It is measured:

- on its own demonstrations (tric-analyze's numbers): the share of the moving steps along which f
  falls, L_g's mean cosine over them, and the selected features;
- offline (tric_control.evaluation.offline: the controller core on the physics, no nodes) on the
  task's training and validation situations: sphere -> sphere_val; cylinder -> cylinder_train,
  cylinder_val; cylinder_b (the second draw of the cylinder demonstrations, bags/cylinder_b) ->
  cylinder_b_train, cylinder_val; cylinder_strat and cylinder_strat_b (both draws stratified over
  the angles) likewise; box -> box_train, box_val; obstacle -> obstacle_val (with the sphere
  model).
All of one robot (--robot: a shipped profile's name or a profile file, docs/robots.md; default
tric_arm_hand): its reference bags (bags/<set> for the paper's robot, bags/ROBOT/<set> for another;
a task without them is refused before any work) and its data sets, in its workspace. DIR holds
one robot's study: another robot's study.json there is refused.

With --every-candidate each candidate is measured on the sets too, and the selection's study is
printed (tric_control.study.selection_report): how each score ranks the candidates against their
validation results, the best of the first S of each group by each score, and the pooled
estimate: the expected result of each score's choice among S of all the variant's candidates
of a task, with its bootstrap sd, and the difference of every two variants of a task that share
candidate seeds, paired by seed (comparisons of variants with less of the choice's noise).
Test sets are never used here: choices are made on training and validation sets; test sets are only
reported (tric-experiments). Candidates are kept in DIR/candidates, the chosen models in
DIR/models, and every finished cell (variant x task x group) is merged into DIR/study.json as it
ends, each keyed on all that made it (the options, the bags' digest, the code's digests:
tric_control.study.runs), so a study can be extended run by run, an interrupted one continues from
its finished cells, cells share the candidates they have in common, and nothing stale is re-used
(each row measured again is named with what changed). DIR is claimed for the run, and every model's
file name checked, before any work. A cell that fails is named with its error; the others are kept.
Candidates (--jobs at once) and episodes run in spawned processes here, or on Ray (the default: a
local instance; --address or RAY_ADDRESS: a cluster, the models and results coming back to DIR).
Prints one row per cell, and per variant the mean, min and max over the groups.
"""

import argparse
import contextlib
import os
import sys

import numpy as np

# Only what the arguments need: --help and argument errors answer before torch, pybullet,
# pinocchio and rclpy are imported (run imports tric_control.study.runs once they are checked).
from tric_control.evaluation.executors import (
    DEFAULT_EXECUTORS,
    add_executor_arguments,
    chosen_executor,
    open_executor,
)
from tric_control.study.staleness import stale_line
from tric_control.study.variants import (
    DEFAULT_TASKS,
    MODEL_MEASURES,
    TASKS,
    model_file_names,
    parse_variant,
)
from tric_sim.tools.claims import claim
from tric_sim.tools.file_names import check_file_names
from tric_sim.tools.interrupts import run_interruptible
from tric_sim.tools.output_files import WriteFailed, check_output_file, check_output_folder
from tric_sim.tools.robot_option import add_robot_option, checked_robot, reference_bags


def format_row(row: dict) -> str:
    if "error" in row:
        return f"{row['variant']:16s} {row['task']:8s} s{row['seed']:<2d} FAILED: {row['error']}"
    m = row["model"]
    kept = "(kept) " if row.get("kept") else ""
    chosen = ",".join(str(seed) for seed in m["chosen"])
    cells = [
        f"{kept}{row['variant']:16s} {row['task']:8s} g{row['seed']:<3d} chose {chosen:8s} "
        f"cos {m['cosine_weighted']:6.3f} "
        f"slow {m['cosine_slow']:6.3f} falls {m['falls']:5.3f} f95 {m['features_95']:3d} "
        f"train {m['train_s']:5.1f}s"
    ]
    for name, s in row["sets"].items():
        if "opened" in s:
            cells.append(f"{name} {s['opened']}/{s['episodes']}")
        else:
            cells.append(
                f"{name} {s['cost_mean']:.3f} good {s['good']}/{s['episodes']} lift {s['lifted']}"
            )
        cells.append(f"rest {s['good_converged']}")
        if s["collisions"]:
            cells.append(f"({s['collisions']} coll.)")
    return "  ".join(cells)


def seed_summary(rows: list) -> str:
    """Per variant and task: each measure's groups and their mean, min and max."""
    lines = []
    groups: dict[tuple, list] = {}
    for row in rows:
        groups.setdefault((row["variant"], row["task"]), []).append(row)
    for (variant, task), group in groups.items():
        measures = {key: [r["model"][key] for r in group] for key in MODEL_MEASURES}
        for name in group[0]["sets"]:
            sets = [r["sets"][name] for r in group]
            if "opened" in sets[0]:
                measures[f"{name} opened"] = [s["opened"] for s in sets]
            else:
                measures[f"{name} cost"] = [s["cost_mean"] for s in sets]
                measures[f"{name} good"] = [s["good"] for s in sets]
                measures[f"{name} lifted"] = [s["lifted"] for s in sets]
            measures[f"{name} at rest"] = [s["good_converged"] for s in sets]
        parts = [
            f"{k} {'/'.join(format(v, '.3g') for v in values)} (mean {np.mean(values):.3g}, "
            f"min {np.min(values):.3g}, max {np.max(values):.3g})"
            for k, values in measures.items()
        ]
        lines.append(f"{variant} / {task} over {len(group)} groups: " + "; ".join(parts))
    return "\n".join(lines)


def main(argv=None) -> int:
    return run_interruptible("tric-study", run, argv, "the rows measured so far kept in study.json")


def run(argv) -> int:
    parser = argparse.ArgumentParser(prog="tric-study", description=__doc__.splitlines()[0])
    parser.add_argument(
        "--variant",
        action="append",
        default=[],
        metavar="NAME=OPTIONS",
        help="a training variant (repeatable; default: 'default=', TrainingConfig's settings)",
    )
    parser.add_argument(
        "--seeds",
        type=int,
        nargs="+",
        default=[0, 100, 200],
        metavar="G",
        help="the groups' seeds: a group's candidates have the seeds G .. G + S - 1 (default 0 "
        "100 200)",
    )
    parser.add_argument(
        "--tasks",
        nargs="+",
        default=list(DEFAULT_TASKS),
        choices=list(TASKS),
        help=f"tasks to measure (default: {' '.join(DEFAULT_TASKS)})",
    )
    parser.add_argument(
        "--every-candidate",
        action="store_true",
        help="measure every candidate on the sets too, and print the selection's study",
    )
    parser.add_argument(
        "--out", default="results/study", help="folder of the models and study.json"
    )
    parser.add_argument(
        "--jobs",
        type=int,
        default=os.cpu_count() or 1,
        help="trainings and offline episodes run at once (default: the number of CPUs)",
    )
    add_executor_arguments(parser, DEFAULT_EXECUTORS["tric-study"])
    add_robot_option(parser)
    args = parser.parse_args(argv)
    try:
        variants = [parse_variant(text) for text in args.variant or ["default="]]
        if any(not 0 <= seed < 2**32 for seed in args.seeds):
            raise ValueError("seeds must be in [0, 2^32)")
        if not 1 <= args.jobs <= 64:
            raise ValueError("--jobs must be in [1, 64]")
        profile = checked_robot(args)
        missing = {str(reference_bags(profile, TASKS[task][0])) for task in args.tasks}
        missing = {folder for folder in missing if not os.path.isdir(folder)}
        if missing:
            raise ValueError(
                f"no reference bags of the robot '{profile.name}' in {', '.join(sorted(missing))} "
                "(relative to the working directory; bags/README.md says how to record them)"
            )
        choice = chosen_executor(args)
        with contextlib.ExitStack() as claims:
            out = claim_folder(args, variants, claims)
            from tric_control.study.runs import Cell, Study

            cells = [
                Cell(name, changes, task, seed)
                for name, changes in variants
                for task in args.tasks
                for seed in args.seeds
            ]
            with open_executor(choice, num_cpus=args.jobs) as executor:
                study = Study(out, args.jobs, executor, args.every_candidate, profile.spec)
                stale = study.stale_rows(cells)
                if stale:
                    print(f"tric-study: {stale_line(stale)}", file=sys.stderr, flush=True)
                rows = study.run(cells, lambda row: print(format_row(row), flush=True))
    except (ValueError, WriteFailed, ConnectionError) as error:
        print(f"tric-study: {error}", file=sys.stderr)
        return 2
    measured = [row for row in rows.values() if "error" not in row]
    print("\n" + "\n".join(format_row(row) for row in rows.values()))
    print("\n" + seed_summary(measured))
    failed = {name: row["error"] for name, row in rows.items() if "error" in row}
    if failed:
        print(f"\n{len(failed)} of {len(rows)} cells failed (the others are kept):")
        print("\n".join(f"  {name}: {error}" for name, error in failed.items()))
    if args.every_candidate:
        from tric_control.study.selection_report import (
            difference_lines,
            report_lines,
            selection_report,
            variant_differences,
        )

        print("\n" + "\n".join(report_lines(selection_report(measured))))
        differences = difference_lines(variant_differences(measured))
        if differences:
            print("\n" + "\n".join(differences))
    print(f"\nwrote {study.path}")
    return 1 if failed else 0


def claim_folder(args, variants, claims: contextlib.ExitStack):
    """The --out folder, checked and claimed for this run (tric_sim.tools.claims, held until claims
    closes) before any work, with its study.json and the name of every model the study may write
    in models/ (no variant given twice, no two models one file, none too long:
    tric_sim.tools.file_names); ValueError naming the problem."""
    out = check_output_folder(args.out, "--out folder")
    claims.enter_context(claim(out, "--out folder", folder=True))
    check_output_file(out / "study.json", what="study file")
    names = model_file_names(variants, args.tasks, args.seeds)
    check_file_names(out / "models", names, "model")
    return out


if __name__ == "__main__":
    sys.exit(main())
