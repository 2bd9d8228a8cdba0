"""A study's runs (tric-study): each variant's models trained on a task's reference bags (or
re-used), measured offline on the task's training and validation sets, and merged into
DIR/study.json."""

import collections
import dataclasses
import hashlib
import json
import math
import pathlib
import time

import numpy as np

from tric_control.episode import DEFAULT_MAX_STEPS
from tric_control.evaluation import task_done, write_json
from tric_control.hard_negatives import train_with_hard_negatives
from tric_control.motion_rate import MAX_LEAD
from tric_control.offline import evaluate_offline
from tric_control.study_variants import MODEL_MEASURES, TASKS, training_part
from tric_learning import analysis, model_file
from tric_learning.bag_dataset import bag_paths, load_dataset
from tric_learning.training import TrainingConfig, train
from tric_sim.metrics import GOOD_GRASP, LID_OPEN_ANGLE
from tric_sim.provenance import code_digest
from tric_sim.robot_model import RobotModel
from tric_sim.scene import TASK_CONTACTS
from tric_sim.situations import dataset

BAGS = pathlib.Path("bags")


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
        bags, sets, kind = TASKS[task]
        max_steps = changes.get(
            "box_steps" if task == "box" else "grasp_steps", DEFAULT_MAX_STEPS[kind]
        )
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
