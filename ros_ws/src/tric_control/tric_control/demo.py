"""tric-demo's job (tric_control.demo_cli checks its arguments first): record the sphere-grid
demonstrations (or reuse bags), train TRIC's candidates and choose the model
(tric_control.selection), evaluate the teacher and TRIC on the 15 test spheres through the nodes,
and write demo.json and the figures."""

import contextlib
import json
import math
import pathlib
import shutil
import time

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from tqdm import tqdm  # noqa: E402

from tric_control.evaluation.executors import ProcessExecutor  # noqa: E402
from tric_control.evaluation.graph import evaluate  # noqa: E402
from tric_control.evaluation.records import report, summarize, write_json  # noqa: E402
from tric_control.experiments.paper import PAPER_TEACHER, PAPER_TRIC  # noqa: E402
from tric_control.experiments.targets import MARGIN_TO_TEACHER  # noqa: E402
from tric_control.selection.select_model import select_from_bags  # noqa: E402
from tric_control.selection.settings import SelectionConfig  # noqa: E402
from tric_learning.demonstrations import demonstrate_all  # noqa: E402
from tric_learning.training.value import TrainingConfig  # noqa: E402
from tric_sim.physics.metrics import GOOD_GRASP  # noqa: E402
from tric_sim.ros.dds_domains import private_domain_id  # noqa: E402
from tric_sim.tools.output_files import atomic_path  # noqa: E402
from tric_sim.viz.view_options import open_view  # noqa: E402
from tric_sim.world.robot_model import RobotModel  # noqa: E402
from tric_sim.world.robot_profile import DEFAULT_ROBOT, RobotProfile  # noqa: E402
from tric_sim.world.situations import dataset  # noqa: E402


def record(out: pathlib.Path, domain_id: int, profile: RobotProfile, view=None) -> pathlib.Path:
    """Demonstrate the robot's sphere grid into out/bags (emptied first), shown in view (a
    FoxgloveView, or None); the folder, or RuntimeError."""
    bags = out / "bags"
    if bags.exists():
        shutil.rmtree(bags)
    rows = demonstrate_all(
        dataset("sphere_train", profile.workspace),
        bags,
        0.125,
        0.0,
        domain_id=domain_id,
        view=view,
        robot=profile.spec,
    )
    failed = [s.name for s, result, path in rows if not (result.success and path)]
    if failed:
        raise RuntimeError(f"the teacher failed to demonstrate {', '.join(failed)}")
    return bags


def train(bags: pathlib.Path, model: pathlib.Path, config: TrainingConfig, jobs: int, robot: str):
    """Train TRIC's candidates on the bags, jobs at once in spawned processes, and choose the
    model (the default selection), with a progress bar; the selection (Selection)."""
    selection = SelectionConfig()
    bar = tqdm(total=selection.candidates, desc="candidates", unit="model")

    def progress(stage, fraction, candidate):
        if stage == "candidates":
            bar.update(round(fraction * selection.candidates) - bar.n)
            if candidate is not None and not isinstance(candidate, Exception):
                bar.set_postfix_str(
                    f"seed {candidate.seed}: trained {candidate.train_s:.0f} s, rolled out "
                    f"{candidate.rollout_s:.0f} s"
                )

    try:
        return select_from_bags(
            [bags], model, config, selection, RobotModel(robot), ProcessExecutor(), jobs, progress
        )
    finally:
        bar.close()


@contextlib.contextmanager
def stage_timer(stages: dict, name: str):
    """stages[name]: the wall seconds the block took."""
    start = time.monotonic()
    yield
    stages[name] = time.monotonic() - start


def comparison_table(teacher, tric, beside_paper: bool = True) -> str:
    """Table 1 (beside the paper's, for the paper's robot): the grasp cost of every test
    situation, then the means."""
    lines = [f"{'test situation':18s} {'teacher':>8s} {'TRIC':>8s} {'TRIC lift':>9s}"]
    for t, r in zip(teacher, tric):
        lines.append(
            f"{r.situation:18s} {t.grasp_cost:8.3f} {r.grasp_cost:8.3f} "
            f"{'yes' if r.lift_passed else 'no':>9s}"
        )
    ts, rs = summarize(teacher), summarize(tric)
    lines.append("-" * len(lines[0]))
    lines.append(
        f"{'mean (ours)':18s} {ts['grasp_cost_mean']:8.3f} {rs['grasp_cost_mean']:8.3f} "
        f"{rs['lift_passed']:>5d}/{len(tric)}"
    )
    if beside_paper:
        lines.append(f"{'mean (paper)':18s} {PAPER_TEACHER:8.3f} {PAPER_TRIC:8.3f} {'-':>9s}")
    return "\n".join(lines)


def plot(teacher, tric, snapshot: pathlib.Path, out: pathlib.Path):
    """demo.png: teacher and TRIC grasp costs per test situation; demo_grasp.png: one TRIC grasp."""
    x = np.arange(len(tric))
    figure, axis = plt.subplots(figsize=(9, 3.6))
    axis.bar(x - 0.2, [r.grasp_cost for r in teacher], 0.4, label="teacher")
    axis.bar(x + 0.2, [r.grasp_cost for r in tric], 0.4, label="TRIC")
    axis.axhline(
        GOOD_GRASP, color="grey", linestyle="--", linewidth=1, label=f"good grasp < {GOOD_GRASP}"
    )
    axis.set_xticks(x, [r.situation.replace("sphere_test_", "") for r in tric])
    axis.set_xlabel("sphere test situation")
    axis.set_ylabel("grasp cost (lower is better)")
    axis.set_title("Table 1: grasping a sphere at unseen positions")
    axis.legend()
    figure.tight_layout()
    with atomic_path(out / "demo.png") as temporary:
        figure.savefig(temporary, dpi=110)
    plt.close(figure)
    if snapshot.is_file():
        with atomic_path(out / "demo_grasp.png") as temporary:
            shutil.copy(snapshot, temporary)


def run_demo(args, out: pathlib.Path) -> int:
    """The job for tric-demo's checked arguments (args) and --out folder (out); the exit status.
    ValueError or RuntimeError when a step cannot be done."""
    started = time.monotonic()
    work = out / "demo"
    work.mkdir(parents=True, exist_ok=True)
    domain_id = private_domain_id()
    view = None
    try:
        view = open_view(args, "tric-demo")
        config = TrainingConfig(max_iterations=args.iterations).validate()
        stages: dict = {}
        with stage_timer(stages, "recording"):
            if args.reuse:
                bags = pathlib.Path(args.reuse)
                print(f"[1/4] reusing the demonstrations in {bags}")
            else:
                print("[1/4] recording the 27 sphere-grid demonstrations with the teacher")
                bags = record(work, domain_id, args.profile, view)
        selection = SelectionConfig()
        print(
            f"[2/4] training {selection.candidates} TRIC candidates (TrainingConfig's defaults: K "
            "= 30, M = 60, docs/fidelity.md), each rolled out from the demonstrations' starts, and "
            "choosing one (docs/decisions/model-selection.md)"
        )
        with stage_timer(stages, "candidates_and_choice"):
            trained = train(bags, work / "tric_sphere.safetensors", config, args.jobs, args.robot)
        info = trained.choice.model.info
        print(
            f"      {trained.path}: seed {', '.join(map(str, trained.choice.chosen))} chosen by "
            f"the score '{selection.score}', {info['selected_features']} selected features, L_n "
            f"{info['losses']['n']:.3f}, L_g {info['losses']['g']:.3f}; trained and chosen in "
            f"{trained.wall_s:.1f} s"
        )
        print("[3/4] the teacher on the 15 test situations")
        tests = dataset("sphere_test", args.profile.workspace)
        with stage_timer(stages, "teacher_evaluation"):
            teacher = evaluate(
                tests,
                None,
                domain_id=domain_id,
                desc="teacher",
                jobs=args.jobs,
                view=view,
                robot=args.robot,
            )
        print("[4/4] TRIC on the 15 test situations")
        snapshots = work / "snapshots"
        with stage_timer(stages, "tric_evaluation"):
            tric = evaluate(
                tests,
                trained.path,
                snapshots=snapshots,
                domain_id=domain_id,
                desc="TRIC",
                jobs=args.jobs,
                view=view,
                robot=args.robot,
            )
    finally:
        if view is not None:
            view.close()
    with stage_timer(stages, "table_and_figures"):
        print("\nTable 1: sphere grasp cost on the 15 test situations\n")
        print(comparison_table(teacher, tric, args.profile.name == DEFAULT_ROBOT))
        ts, rs = summarize(teacher), summarize(tric)
        best = min(tric, key=lambda r: r.grasp_cost if math.isfinite(r.grasp_cost) else math.inf)
        plot(teacher, tric, snapshots / f"{best.situation}.png", out)
    total = time.monotonic() - started
    candidates = trained.choice.provenance["candidates"]
    summary = {
        "teacher_cost_mean": ts["grasp_cost_mean"],
        "tric_cost_mean": rs["grasp_cost_mean"],
        "tric_cost_max": rs["grasp_cost_max"],
        "tric_lift_passed": rs["lift_passed"],
        "episodes": len(teacher) + len(tric),
        "train_s": trained.wall_s,
        "total_s": total,
        # wall seconds of each stage; the candidates' training and rollouts summed over the
        # processes they ran in (CPU-bound, so about jobs times their share of the stage's wall)
        "stages_s": {
            **stages,
            "candidates_training_summed": sum(row["train_s"] for row in candidates),
            "candidates_rollouts_summed": sum(row["rollout_s"] for row in candidates),
        },
    }
    write_json(
        out / "demo.json",
        {
            **summary,
            "robot": args.profile.name,
            "model": str(trained.path),
            "bags": str(bags),
            "training": {
                "losses": info["losses"],
                "selected_features": info["selected_features"],
                "chosen": trained.choice.chosen,
                "candidates": [
                    {key: row[key] for key in ("seed", "score", "chosen", "train_s", "rollout_s")}
                    for row in candidates
                ],
            },
            "tric": report(tric),
            "teacher": report(teacher),
        },
    )
    within = rs["grasp_cost_mean"] <= ts["grasp_cost_mean"] + MARGIN_TO_TEACHER
    all_good = rs["good_grasps"] == len(tric)
    print(
        f"\nTRIC mean within {MARGIN_TO_TEACHER} of the teacher: {'met' if within else 'NOT met'}; "
        f"every TRIC grasp below {GOOD_GRASP}: {'met' if all_good else 'NOT met'}"
    )
    print(
        f"wrote {out / 'demo.json'}, {out / 'demo.png'} and {out / 'demo_grasp.png'} "
        f"({best.situation}); total {total:.0f} s"
    )
    print(json.dumps(summary, indent=2))
    return 1 if args.check and not (within and all_good) else 0
