"""tric-study: compare training variants of TRIC on the training and validation sets, over seeds.

    tric-study [--variant NAME=OPTIONS ...] [--seeds S ...] [--tasks TASK ...] [--out DIR] [--jobs
    N]

A variant is a name and TrainingConfig fields to change from the defaults, e.g.
`--variant balanced=per_step_weights=true,optimizer=lbfgsb,alpha_g=3` (no options: the defaults),
and controller settings: hand_lead (rad: how far the command may lead the measured hand joints,
motion_rate.MAX_HAND_LEAD by default), grasp_steps and box_steps (the episodes' step budgets), and
hard_negative_rounds (rounds of training again on the controller's own rollouts in the training
situations: tric_control.hard_negatives). Variants that differ only in controller settings share
their models.
For each variant, seed and task, a model is trained on the reference bags of the task (the seed
draws the noisy samples and the initial weights) and measured:

- on its own demonstrations (tric-analyze's numbers): the share of the moving steps along which f
  falls, L_g's mean cosine over them, and the selected features;
- offline (tric_control.offline: the controller core on the physics, no nodes) on the task's
  training and validation situations: sphere -> sphere_val; cylinder -> cylinder_train,
  cylinder_val; cylinder_b (the second draw of the cylinder demonstrations, bags/cylinder_b) ->
  cylinder_b_train, cylinder_val; cylinder_strat and cylinder_strat_b (both draws stratified over
  the angles) likewise; box -> box_train, box_val; obstacle -> obstacle_val (with the sphere
  model).

Test sets are never used here: choices are made on training and validation sets; test sets are only
reported (tric-experiments). Models are kept in DIR/models and re-used; every result is merged into
DIR/study.json, so a study can be extended run by run. Prints one row per variant, seed and task,
and per variant the mean, min and max over the seeds.
"""

import argparse
import collections
import dataclasses
import hashlib
import json
import math
import os
import pathlib
import sys
import time

import numpy as np

from tric_control.episode import DEFAULT_MAX_STEPS
from tric_control.evaluation import task_done, write_json
from tric_control.hard_negatives import train_with_hard_negatives
from tric_control.motion_rate import MAX_LEAD
from tric_control.offline import evaluate_offline
from tric_learning import analysis, model_file
from tric_learning.bag_dataset import bag_paths, load_dataset
from tric_learning.training import TrainingConfig, train
from tric_sim.interrupts import run_interruptible
from tric_sim.metrics import GOOD_GRASP, LID_OPEN_ANGLE
from tric_sim.provenance import code_digest
from tric_sim.robot_model import RobotModel
from tric_sim.scene import TASK_CONTACTS
from tric_sim.situations import dataset

BAGS = pathlib.Path("bags")
#: Each task: the bags its model is trained on, the sets it is measured on, its episodes' step
#: budget (the controller's default for the task, tric_control.episode.DEFAULT_MAX_STEPS).
TASKS = {
    "sphere": ("sphere", ("sphere_val",), DEFAULT_MAX_STEPS["grasp"]),
    "cylinder": ("cylinder", ("cylinder_train", "cylinder_val"), DEFAULT_MAX_STEPS["grasp"]),
    # a second draw of the cylinder demonstrations, and both draws stratified over the angles
    "cylinder_b": ("cylinder_b", ("cylinder_b_train", "cylinder_val"), DEFAULT_MAX_STEPS["grasp"]),
    "cylinder_strat": (
        "cylinder_strat",
        ("cylinder_strat_train", "cylinder_val"),
        DEFAULT_MAX_STEPS["grasp"],
    ),
    "cylinder_strat_b": (
        "cylinder_strat_b",
        ("cylinder_strat_b_train", "cylinder_val"),
        DEFAULT_MAX_STEPS["grasp"],
    ),
    "box": ("box", ("box_train", "box_val"), DEFAULT_MAX_STEPS["open_box"]),
    "obstacle": ("sphere", ("obstacle_val",), DEFAULT_MAX_STEPS["grasp"]),
}


#: The tasks a study measures unless told otherwise.
DEFAULT_TASKS = ("sphere", "cylinder", "cylinder_b", "box", "obstacle")


#: The analysis' numbers of a model on its own demonstrations that a study records
#: (tric_learning.analysis.key_numbers: gradient_measures and features_carrying).
MODEL_MEASURES = (
    "cosine_weighted",
    "cosine_moving",
    "cosine_slow",
    "falls",
    "falls_moving",
    "features_95",
)


#: Controller settings a variant may change, with their types: the hand's lead, the step budgets,
#: the task's contact rules (tric_sim.scene.TASK_CONTACTS): how deep the hand may press into a
#: grasp target and its cushion (m), how deep into the lid (m) and whether only from beneath; and
#: whether the domain damper (tric_control.limits.DomainDamper) is among the limits.
CONTROLLER_OPTIONS = {
    "hand_lead": float,
    "grasp_steps": int,
    "box_steps": int,
    "grasp_depth": float,
    "grasp_cushion": float,
    "lid_depth": float,
    "lid_beneath_only": bool,
    "domain_damper": bool,
}
#: Training procedures beyond TrainingConfig: rounds of hard negatives
#: (tric_control.hard_negatives).
PROCEDURE_OPTIONS = {"hard_negative_rounds": int}


def parse_variant(text: str):
    """(name, {field: value}) from NAME=FIELD=VALUE,FIELD=VALUE (TrainingConfig fields and
    CONTROLLER_OPTIONS); ValueError naming a bad part."""
    name, _, options = text.partition("=")
    if not name or not name.replace("_", "").replace("-", "").isalnum():
        raise ValueError(f"variant '{text}': the name must be letters, digits, - and _")
    fields = {f.name: f for f in dataclasses.fields(TrainingConfig)}
    changes = {}
    for option in filter(None, options.split(",")):
        key, _, value = option.partition("=")
        extras = {**CONTROLLER_OPTIONS, **PROCEDURE_OPTIONS}
        if (key not in fields and key not in extras) or key == "seed":
            raise ValueError(
                f"variant '{name}': unknown option '{key}' (known: "
                f"{', '.join([k for k in fields if k != 'seed'] + list(extras))})"
            )
        kind = extras[key] if key in extras else type(getattr(TrainingConfig(), key))
        if kind is bool:
            if value.lower() not in ("true", "false"):
                raise ValueError(f"variant '{name}': {key} must be true or false")
            changes[key] = value.lower() == "true"
        else:
            try:
                changes[key] = kind(value)
            except ValueError:
                raise ValueError(
                    f"variant '{name}': {key} must be a {kind.__name__}, got '{value}'"
                ) from None
    TrainingConfig(**training_part(changes)).validate()
    if (
        changes.get("hand_lead", 0.0) < 0
        or changes.get("grasp_steps", 1) < 1
        or changes.get("box_steps", 1) < 1
    ):
        raise ValueError(
            f"variant '{name}': hand_lead must be >= 0 rad and the step budgets >= 1 tick"
        )
    if any(not 0 <= changes.get(key, 0.0) <= 0.05 for key in CONTACT_OPTIONS):
        raise ValueError(f"variant '{name}': contact depths and cushions must be in [0, 0.05] m")
    if changes.get("hard_negative_rounds", 0) < 0:
        raise ValueError(f"variant '{name}': hard_negative_rounds must be >= 0")
    return name, changes


#: The contact options of CONTROLLER_OPTIONS given in metres.
CONTACT_OPTIONS = ("grasp_depth", "grasp_cushion", "lid_depth")


def contact_rules(changes: dict, task: str):
    """The contacts ({scene body name: tric_sim.scene.Contact}) a variant's contact options make of
    the task's, or None when it changes none of them."""
    if task == "open_box":
        if "lid_depth" not in changes and "lid_beneath_only" not in changes:
            return None
        lid = TASK_CONTACTS["open_box"]["lid"]
        beneath = changes.get("lid_beneath_only", lid.side is not None)
        return {
            "lid": dataclasses.replace(
                lid,
                depth=changes.get("lid_depth", lid.depth),
                side=(0.0, 0.0, -1.0) if beneath else None,
            )
        }
    if "grasp_depth" not in changes and "grasp_cushion" not in changes:
        return None
    target = TASK_CONTACTS["grasp"]["target"]
    return {
        "object": dataclasses.replace(
            target,
            depth=changes.get("grasp_depth", target.depth),
            cushion=changes.get("grasp_cushion", target.cushion),
        )
    }


def training_part(changes: dict) -> dict:
    """The TrainingConfig fields (but the seed) of a variant's changes or a model's record."""
    fields = {f.name for f in dataclasses.fields(TrainingConfig)} - {"seed"}
    return {k: v for k, v in changes.items() if k in fields}


def measure_set(records) -> dict:
    """Summary numbers of one set's offline episodes."""
    grasps = [r for r in records if r.task == "grasp"]
    rest = {
        "converged": sum(r.outcome == "converged" for r in records),
        "good_converged": sum(r.outcome == "converged" for r in records if task_done(r)),
        "collisions": sum(bool(r.collided) for r in records),
        "overshoot": max(r.max_joint_overshoot for r in records),
        "failures": dict(collections.Counter(r.failure for r in records if r.failure)),
    }
    if grasps:
        costs = [r.grasp_cost for r in grasps if math.isfinite(r.grasp_cost)]
        return {
            "episodes": len(records),
            "cost_mean": float(np.mean(costs)) if costs else math.nan,
            "good": sum(r.grasp_cost < GOOD_GRASP for r in grasps),
            "lifted": sum(r.lift_passed is True for r in grasps),
            **rest,
        }
    return {
        "episodes": len(records),
        "opened": sum(r.lid_angle > LID_OPEN_ANGLE for r in records),
        "lid_mean": float(np.mean([r.lid_angle for r in records])),
        **rest,
    }


class Study:
    """Trains, measures and records; results merged into out/study.json."""

    def __init__(self, out: pathlib.Path, jobs: int):
        self.out, self.jobs = out, jobs
        self.robot = RobotModel()
        self.path = out / "study.json"
        self.results = json.loads(self.path.read_text()) if self.path.is_file() else {}
        self._datasets = {}
        (out / "models").mkdir(parents=True, exist_ok=True)

    def demonstrations(self, bags: str):
        if bags not in self._datasets:
            self._datasets[bags] = load_dataset(bag_paths([BAGS / bags]), self.robot)
        return self._datasets[bags]

    def model(self, variant: str, changes: dict, bags: str, seed: int, max_steps: int) -> tuple:
        """(model path, its training record) of the variant's training options on the bags with the
        seed, trained unless a model of the same options was (by any variant). Hard negatives roll
        the controller out for max_steps ticks."""
        rounds = changes.get("hard_negative_rounds", 0)
        config = {
            **training_part(changes),
            "seed": seed,
            **({"hard_negative_rounds": rounds} if rounds else {}),
            "bags_digest": self.bags_digest(bags),
            "training_code": code_digest(
                "tric_control.hard_negatives" if rounds else "tric_learning.training"
            ),
        }
        for key, record in self.results.get("models", {}).items():
            path = self._model_path(key)
            if key.split("/")[1] == bags and record["config"] == config and path.is_file():
                return path, record
        key = f"{variant}/{bags}/{seed}"
        path = self._model_path(key)
        demos = self.demonstrations(bags)
        print(f"training {variant} on {BAGS / bags}, seed {seed}", flush=True)
        started = time.perf_counter()
        if rounds:
            result = train_with_hard_negatives(
                demos,
                self.robot,
                TrainingConfig(**training_part(config), seed=seed),
                rounds,
                max_steps,
            )
        else:
            result = train(demos, self.robot, TrainingConfig(**training_part(config), seed=seed))
        model_file.from_training(result, demos).save(path)
        numbers = analysis.key_numbers(result.model, demos, 20)
        record = {
            "config": config,
            "train_s": time.perf_counter() - started,
            "iterations": result.iterations,
            "losses": result.losses,
            **{key: numbers[key] for key in MODEL_MEASURES},
            "selected_features": numbers["selected_features"],
            "kept_features": numbers["kept_features"],
        }
        self.results.setdefault("models", {})[key] = record
        self.save()
        return path, record

    @staticmethod
    def bags_digest(bags: str) -> str:
        """A digest of the bags' contents: a model trained on other bags of the same name is not
        re-used."""
        digest = hashlib.sha1()
        for path in bag_paths([BAGS / bags]):
            digest.update(path.name.encode())
            digest.update(path.read_bytes())
        return digest.hexdigest()[:12]

    def _model_path(self, key: str) -> pathlib.Path:
        variant, bags, seed = key.split("/")
        return self.out / "models" / f"{variant}_{bags}_s{seed}.safetensors"

    def run(self, variant: str, changes: dict, task: str, seed: int) -> dict:
        bags, sets, max_steps = TASKS[task]
        max_steps = changes.get("box_steps" if task == "box" else "grasp_steps", max_steps)
        options = {}
        if "hand_lead" in changes:
            lead = np.full(self.robot.n_joints, MAX_LEAD)
            lead[self.robot.hand_indices] = changes["hand_lead"]
            options["max_lead"] = lead
        if "domain_damper" in changes:
            options["domain_damper"] = changes["domain_damper"]
        contacts = contact_rules(changes, "open_box" if task == "box" else "grasp")
        if contacts is not None:
            options["contacts"] = contacts
        path, record = self.model(variant, changes, bags, seed, max_steps)
        row = {
            "variant": variant,
            "task": task,
            "seed": seed,
            "changes": changes,
            "model": record,
            "sets": {},
        }
        for name in sets:
            records = evaluate_offline(
                dataset(name),
                str(path),
                max_steps,
                jobs=self.jobs,
                desc=f"{variant} s{seed} {name}",
                controller_options=options,
            )
            row["sets"][name] = measure_set(records)
        row["date"] = time.strftime("%Y-%m-%d %H:%M")
        self.results.setdefault("rows", {})[f"{variant}/{task}/{seed}"] = row
        self.save()
        return row

    def save(self):
        """Merge this study's models and rows into the file (another study may have written it
        since)."""
        merged = json.loads(self.path.read_text()) if self.path.is_file() else {}
        for part in ("models", "rows"):
            merged.setdefault(part, {}).update(self.results.get(part, {}))
        self.results = merged
        write_json(self.path, merged)


def format_row(row: dict) -> str:
    m = row["model"]
    cells = [
        f"{row['variant']:16s} {row['task']:8s} s{row['seed']:<2d} cos {m['cosine_weighted']:6.3f} "
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
    """Per variant and task: each measure's seeds and their mean, min and max."""
    lines = []
    groups = {}
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
        lines.append(f"{variant} / {task} over {len(group)} seeds: " + "; ".join(parts))
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
        "--seeds", type=int, nargs="+", default=[0, 1, 2], help="training seeds (default 0 1 2)"
    )
    parser.add_argument(
        "--tasks",
        nargs="+",
        default=list(DEFAULT_TASKS),
        choices=list(TASKS),
        help=f"tasks to measure (default: {' '.join(DEFAULT_TASKS)})",
    )
    parser.add_argument(
        "--out", default="results/study", help="folder of the models and study.json"
    )
    parser.add_argument(
        "--jobs", type=int, default=os.cpu_count() or 1, help="offline episodes run at once"
    )
    args = parser.parse_args(argv)
    try:
        variants = [parse_variant(text) for text in args.variant or ["default="]]
        if any(not 0 <= seed < 2**32 for seed in args.seeds):
            raise ValueError("seeds must be in [0, 2^32)")
        if not 1 <= args.jobs <= 64:
            raise ValueError("--jobs must be in [1, 64]")
        study = Study(pathlib.Path(args.out), args.jobs)
        rows = []
        for name, changes in variants:
            for task in args.tasks:
                for seed in args.seeds:
                    rows.append(study.run(name, changes, task, seed))
                    print(format_row(rows[-1]), flush=True)
    except ValueError as error:
        print(f"tric-study: {error}", file=sys.stderr)
        return 2
    print("\n" + "\n".join(format_row(row) for row in rows))
    print("\n" + seed_summary(rows))
    print(f"\nwrote {study.path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
