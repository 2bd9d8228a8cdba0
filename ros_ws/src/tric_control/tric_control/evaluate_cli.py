"""tric-eval: run a model (or the teacher) on situations through the real nodes, and judge it.

    tric-eval (--model MODEL | --teacher) (DATASET | --situations-file FILE) [--json OUT
              [--overwrite]] [--max-steps N]
              [[--fall-pace-knee K] [--stall-escapes N] | --protocol paper]
              [--snapshots DIR]
              [--domain-id N] [--jobs N] [--robot ROBOT]
              [--executor processes|ray] [--address HOST:PORT] [--offline] [--record DIR]
              [--viz [--viz-port P]] [--perturb KIND:SIZE[@SECONDS] ...]

Runs the simulator (lockstep), the teacher and the controller nodes in one process. For each
situation: reset the scene (/simulator/reset_scene); the teacher demonstrates it
(/teacher/demonstrate) or the controller runs the loaded model for one episode
(/controller/execute); then the simulator judges the final state with the hidden metrics
(/simulator/evaluate_task, with the lift test for grasps). Prints a table, and writes the
per-episode records and their summary to the --json file. DATASET is a built-in data set
(sphere_test, cylinder_test, obstacle_test, box_test, ...), in the robot's workspace (its
profile's); any YAML/JSON situations file of one task works too. --robot: the robot (a shipped
profile's name or a profile file, docs/robots.md; default tric_arm_hand); a model made for another
robot is refused. --snapshots DIR writes a PNG of each final state (before the lift test). The
--json file and the --snapshots folder are checked before the first episode (the --json file must
not be the model or the situations file, nor exist unless --overwrite), claimed for this run
(another run naming them is refused, naming this one's PID), with the name of every picture and bag
the episodes will write; a result is written atomically, never over a file that appeared meanwhile
unless --overwrite. Each episode judged is kept in the --json file's .partial with the key of all
that made it (tric_control.evaluation.partial); --resume runs only the episodes not kept with this
run's key, naming those dropped. The nodes run in a private DDS domain unless --domain-id names one.
--jobs N runs N such graphs at once, each in a worker process of its own on its own domain (the base
one and the N - 1 above it), the situations shared out one at a time; the records keep the
situations' order. The workers are spawned processes here, or Ray actors (--executor ray: a local
Ray instance; --address or RAY_ADDRESS: a Ray cluster whose machines have the project's environment,
the model file and the code shipped to them, the records coming back; not with --snapshots, --record
or --viz, which write on the workers' disks). --offline runs the same episodes without nodes: the
controller core (or the teacher's) on the physics directly (tric_control.evaluation.offline),
several times faster, for sweeps; the table and JSON are the same. --record DIR writes one bag per
episode (the recorder node: the joint states, poses, samples and outcome, the controller's status of
every tick, and /tf, /robot_description and /scene_markers for Foxglove to replay it in 3D). --viz
serves a live Foxglove view of the run (tric_sim.viz.foxglove_view) on ws://127.0.0.1:P (default
8765); it shows one graph, so it takes --jobs 1. --record and --viz need the nodes (not --offline).
--perturb puts each situation through perturbed trials instead (tric_sim.world.perturbation_trials):
push:SIZE shoves the arm by SIZE rad over 0.1 s, jolt:SIZE within one control period (it moves an
arm held at rest), jump:SIZE moves the grasp target SIZE m sideways at once, drift:SIZE moves it at
SIZE m/s, start:SIZE starts SIZE rad from the nominal start; @SECONDS sets when (default 1 s for
grasps, 4 s for boxes); the episode runs at least 0.5 s past its last perturbation. Each --perturb
value gives one episode per situation, named "<situation>_<kind><size>"; the perturbations are in
the situation the episode runs (and in its bag, with --record). Exits 0 when every episode ran
(whatever its score), 1 when one could not be run, 2 on bad arguments."""

import argparse
import contextlib
import pathlib
import sys

# Only what the arguments need: --help and argument errors answer before torch, pybullet,
# pinocchio and rclpy are imported (main imports the rest once the arguments are checked).
from tric_control.evaluation.executors import (
    DEFAULT_EXECUTORS,
    add_executor_arguments,
    chosen_executor,
    open_executor,
)
from tric_sim.ros.dds_domains import MAX_DOMAIN_ID, private_domain_id
from tric_sim.ros.fields import INTEGER_RANGES
from tric_sim.tools.claims import claim
from tric_sim.tools.file_names import check_file_names, safe_stem
from tric_sim.tools.interrupts import run_interruptible
from tric_sim.tools.output_files import PARTIAL_SUFFIX, check_output_file, check_output_folder
from tric_sim.tools.provenance import code_digest
from tric_sim.tools.robot_option import add_robot_option, checked_robot
from tric_sim.tools.untrusted import check_input_file
from tric_sim.viz.view_options import add_view_arguments, open_view
from tric_sim.world.perturbation_trials import parse_trial
from tric_sim.world.robot_profile import load_profile
from tric_sim.world.situation_files import load_situations
from tric_sim.world.situations import DATASETS, dataset

#: What --json takes per episode at most, bytes (a record is about 600).
JSON_BYTES_PER_EPISODE = 4096
#: The largest --max-steps: the Execute goal's max_steps is a uint32.
MAX_STEPS = INTEGER_RANGES["uint32"][1]


def main(argv=None) -> int:
    return run_interruptible(
        "tric-eval", run, argv, "with --json, the episodes judged so far kept (--resume continues)"
    )


def run(argv) -> int:
    parser = argparse.ArgumentParser(prog="tric-eval", description=__doc__.splitlines()[0])
    agent = parser.add_mutually_exclusive_group(required=True)
    agent.add_argument("--model", help="a model file (from tric-train or the trainer node)")
    agent.add_argument(
        "--teacher", action="store_true", help="evaluate the teacher instead of a model"
    )
    parser.add_argument("dataset", nargs="?", choices=sorted(DATASETS), help="a built-in data set")
    parser.add_argument("--situations-file", help="a YAML/JSON situations file instead of DATASET")
    add_robot_option(parser)
    parser.add_argument("--json", help="write the per-episode records and the summary to this file")
    parser.add_argument(
        "--overwrite", action="store_true", help="replace the --json file if it exists"
    )
    parser.add_argument(
        "--resume",
        action="store_true",
        help="continue an interrupted run from the episodes kept in the --json file's .partial",
    )
    parser.add_argument(
        "--max-steps",
        type=int,
        default=0,
        help="control ticks per episode at most (default: the controller's, 1200 for a grasp, 2000 "
        "for a box; an episode ends sooner at rest)",
    )
    parser.add_argument(
        "--protocol",
        choices=("ours", "paper"),
        default="ours",
        help="paper: every episode 500 ticks at most, with the paper's constant delta (Sec. "
        "5.2.3: delta makes 500 ticks from a demonstration's start to its end; no fall pace, no "
        "stall escape); ours: the controller's budgets, pace and escape (default %(default)s)",
    )
    parser.add_argument(
        "--fall-pace-knee",
        type=float,
        metavar="K",
        help="the controller's fall_pace_knee parameter in [0, 1] (default: the node's, 0.25; 0: "
        "the paper's constant delta; docs/decisions/fall-pace.md)",
    )
    parser.add_argument(
        "--stall-escapes",
        type=int,
        metavar="N",
        help="the controller's stall_escapes parameter, >= 0: random walks out of a rest far above "
        "where the model's rollouts rested (default: the node's, 3; 0: none, the paper's; "
        "docs/decisions/stall-escape.md)",
    )
    parser.add_argument("--snapshots", help="write a PNG of each final state into this folder")
    parser.add_argument(
        "--domain-id",
        type=int,
        default=None,
        help="DDS domain of the in-process nodes (default: a private one, 1 + pid %% 100)",
    )
    parser.add_argument(
        "--jobs",
        type=int,
        default=1,
        help="evaluation graphs run at once, each in a process on its own domain (default 1)",
    )
    add_executor_arguments(parser, DEFAULT_EXECUTORS["tric-eval"])
    parser.add_argument(
        "--offline",
        action="store_true",
        help="run the controller core (or the teacher's) on the physics directly, without nodes",
    )
    parser.add_argument(
        "--record",
        metavar="DIR",
        help="write one bag per episode into DIR (with the controller's status, /tf and markers)",
    )
    parser.add_argument(
        "--perturb",
        metavar="KIND:SIZE[@SECONDS]",
        action="append",
        type=_trial,
        default=[],
        help="run each situation perturbed: push:RAD, jolt:RAD, jump:M, drift:M_PER_S or start:RAD "
        "(repeatable: one episode per value and situation)",
    )
    add_view_arguments(parser)
    args = parser.parse_args(argv)
    if bool(args.dataset) == bool(args.situations_file):
        parser.error("give either DATASET or --situations-file")
    if args.resume and not args.json:
        parser.error("--resume continues a run that keeps its episodes: give its --json file")
    if not 0 <= args.max_steps <= MAX_STEPS:
        parser.error(f"--max-steps must be in [0, {MAX_STEPS}] (0: the controller's default)")
    if args.fall_pace_knee is not None and not 0 <= args.fall_pace_knee <= 1:
        parser.error("--fall-pace-knee must be in [0, 1] (0: the paper's constant delta)")
    if args.stall_escapes is not None and args.stall_escapes < 0:
        parser.error("--stall-escapes must be >= 0 (0: none)")
    controller = {} if args.fall_pace_knee is None else {"fall_pace_knee": args.fall_pace_knee}
    if args.stall_escapes is not None:
        controller["stall_escapes"] = args.stall_escapes
    if args.protocol == "paper":
        if args.max_steps or controller:
            parser.error(
                "--protocol paper sets the budget and delta: not with --max-steps, "
                "--fall-pace-knee or --stall-escapes"
            )
        from tric_control.controller_parameters import PAPER_CONTROLLER
        from tric_control.episode_runner import PAPER_STEPS

        args.max_steps, controller = PAPER_STEPS, dict(PAPER_CONTROLLER)
    args.controller = controller
    domain_id = private_domain_id() if args.domain_id is None else args.domain_id
    if not 1 <= args.jobs <= 64:
        parser.error("--jobs must be in [1, 64]")
    if not 0 <= domain_id <= MAX_DOMAIN_ID - args.jobs + 1:
        parser.error(
            f"--domain-id must be in [0, {MAX_DOMAIN_ID - args.jobs + 1}] with --jobs {args.jobs}"
        )
    if args.viz and args.jobs > 1:
        parser.error("--viz shows one evaluation graph: use --jobs 1")
    try:
        executor = chosen_executor(args)
    except ValueError as error:
        parser.error(str(error))
    on_this_disk = args.snapshots or args.record
    if executor.kind == "ray" and (args.viz or (executor.remote and on_this_disk)):
        parser.error("--viz, and on a cluster --snapshots and --record, need workers here")
    if args.offline and (args.viz or args.record):
        parser.error("--viz and --record watch the nodes: not with --offline")
    with contextlib.ExitStack() as claims:
        return evaluate_and_report(args, executor, domain_id, claims)


def evaluate_and_report(args, executor, domain_id: int, claims: contextlib.ExitStack) -> int:
    """Check and claim the outputs, run the episodes not kept yet, print the table and write the
    --json file; the exit status."""
    view = None
    name = "teacher" if args.teacher else args.model
    try:
        profile = checked_robot(args)
        args.robot = profile.spec
        situations = (
            load_situations(args.situations_file)
            if args.situations_file
            else dataset(args.dataset, profile.workspace)
        )
        if args.perturb:
            from tric_sim.world.robot_model import RobotModel

            robot = RobotModel(args.robot)
            situations = [
                trial.apply(situation, robot) for situation in situations for trial in args.perturb
            ]
        model = None if args.teacher else str(check_input_file(args.model, "model file"))
        claim_outputs(args, situations, claims)
        from tric_control.evaluation.graph import evaluate
        from tric_control.evaluation.offline import evaluate_offline
        from tric_control.evaluation.partial import dropped_line

        kept = kept_records(args, model, situations)
        done, dropped = kept.resume() if kept is not None and args.resume else ({}, [])
        if kept is not None and done:
            print(f"tric-eval: {len(done)} episodes kept in {kept.path}", file=sys.stderr)
        if dropped:
            print(f"tric-eval: {dropped_line(dropped)}", file=sys.stderr)
        todo = [situation for situation in situations if situation.name not in done]
        on_record = kept.add if kept is not None else None
        if not todo:
            new = []
        else:
            view = None if args.offline else open_view(args, "tric-eval")
            with open_executor(executor, num_cpus=args.jobs) as workers:
                if args.offline:
                    new = evaluate_offline(
                        todo,
                        model,
                        args.max_steps,
                        args.snapshots,
                        jobs=args.jobs,
                        on_record=on_record,
                        executor=workers,
                        robot=args.robot,
                        controller_options=args.controller,
                    )
                else:
                    new = evaluate(
                        todo,
                        model,
                        args.max_steps,
                        args.snapshots,
                        domain_id=domain_id,
                        jobs=args.jobs,
                        view=view,
                        record=args.record,
                        on_record=on_record,
                        executor=workers,
                        robot=args.robot,
                        controller=args.controller,
                    )
        judged = {**done, **{record.situation: record for record in new}}
        records = [judged[situation.name] for situation in situations]
    except (ValueError, ConnectionError) as error:
        print(f"tric-eval: {error}", file=sys.stderr)
        return 2
    finally:
        if view is not None:
            view.close()
    from tric_control.evaluation.records import report, table, write_json

    print(
        table(
            records,
            f"\n{name} on {args.dataset or args.situations_file}"
            + (" (offline)" if args.offline else ""),
        )
    )
    if kept is not None:
        try:
            result = {"agent": name, **report(records)}
            print(f"wrote {write_json(args.json, result, replace=args.overwrite)}")
        except OSError as error:
            print(f"tric-eval: {error.strerror}", file=sys.stderr)
            return 2
        kept.remove()
    return 1 if any(r.failed for r in records) else 0


def claim_outputs(args, situations, claims: contextlib.ExitStack) -> None:
    """Check every output before any work, and claim it for this run (tric_sim.tools.claims, held
    until claims closes): the --json file (and its .partial: without --resume, one there is
    refused unless --overwrite), the --snapshots and --record folders, and the file each episode
    will write into them (tric_sim.tools.file_names)."""
    inputs = (args.model, args.situations_file)
    if args.json:
        check_output_file(
            args.json,
            what="--json file",
            inputs=inputs,
            overwrite=args.overwrite,
            expected_bytes=JSON_BYTES_PER_EPISODE * len(situations),
        )
        claims.enter_context(claim(args.json, "--json file"))
        partial = pathlib.Path(args.json + PARTIAL_SUFFIX)
        if partial.exists() and not args.resume and not args.overwrite:
            raise ValueError(
                f"{partial} holds the episodes of an interrupted run: give --resume to continue "
                "it, or --overwrite to start anew"
            )
    outputs = (
        (args.snapshots, "--snapshots folder", "picture", ".png", str),
        (args.record, "--record folder", "bag", ".mcap", safe_stem),
    )
    for folder, what, item, suffix, stem in outputs:
        if folder:
            check_output_folder(folder, what)
            claims.enter_context(claim(folder, what, folder=True))
            names = {situation.name: stem(situation.name) + suffix for situation in situations}
            check_file_names(folder, names, item, inputs=inputs)


def kept_records(args, model, situations):
    """The PartialRecords of a run with --json (None without), keyed on all that makes its
    episodes (tric_control.evaluation.partial)."""
    if not args.json:
        return None
    from tric_control.evaluation.partial import PartialRecords, agent_digest

    # the robot's profile file and URDF are part of what made an episode
    runs = f"{'offline' if args.offline else 'nodes'}, robot {load_profile(args.robot).digest}"
    runs += "".join(f", {name} {value!r}" for name, value in sorted(args.controller.items()))
    code = code_digest(f"tric_control.evaluation.{'offline' if args.offline else 'graph'}")
    kept = PartialRecords(args.json, agent_digest(model), situations, args.max_steps, runs, code)
    if not args.resume:
        kept.remove()
    return kept


def _trial(text: str):
    try:
        return parse_trial(text)
    except ValueError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


if __name__ == "__main__":
    sys.exit(main())
