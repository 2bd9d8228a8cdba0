"""A study's runs (tric-study): its cells (variant x task x seed) each train a model on the task's
reference bags (or re-use one) and measure it offline on the task's training and validation sets;
trainings and episodes run on an executor (tric_control.evaluation.executors: processes here, or
Ray), and every finished cell is merged into DIR/study.json at once.

Nothing stale is re-used: a model is keyed on its training options, seed, the bags' digest and the
digests of the training and analysis code (tric_sim.tools.provenance.code_digest); a finished cell
on its model's key, its controller options, step budget, sets and the digest of the episodes' code.
An interrupted study run again does only the cells whose key has no finished row; a cell that fails
is named with its error, and the others are kept."""

import collections
import dataclasses
import hashlib
import json
import math
import pathlib
import tempfile
import time

import numpy as np

from tric_control.episode_runner import DEFAULT_MAX_STEPS
from tric_control.evaluation.offline import evaluate_offline
from tric_control.evaluation.records import task_done, write_json
from tric_control.motion_rate import MAX_LEAD
from tric_control.study.hard_negatives import train_with_hard_negatives
from tric_control.study.staleness import key_changes
from tric_control.study.variants import (
    CONTROLLER_OPTIONS,
    MODEL_MEASURES,
    TASKS,
    model_file_name,
    training_part,
)
from tric_learning import analysis, model_file
from tric_learning.bags.loader import bag_paths, load_dataset
from tric_learning.training.lbfgs import torch_threads
from tric_learning.training.value import TrainingConfig, train
from tric_sim.physics.metrics import GOOD_GRASP, LID_OPEN_ANGLE
from tric_sim.tools.output_files import atomic_path
from tric_sim.tools.provenance import code_digest
from tric_sim.tools.untrusted import read_data_file
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.scene import TASK_CONTACTS
from tric_sim.world.situations import dataset

BAGS = pathlib.Path("bags")
#: PyTorch's threads in every training of a study: the same model on every executor and machine
#: core count, and trainings that run side by side on one CPU each.
TRAINING_THREADS = 1


def contact_rules(changes: dict, task: str):
    """The contacts ({scene body name: tric_sim.world.scene.Contact}) a variant's contact options
    make of the task's, or None when it changes none of them."""
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


@dataclasses.dataclass(frozen=True)
class Cell:
    """One cell of a study: a variant (its name and changes) on a task with a training seed."""

    variant: str
    changes: dict
    task: str
    seed: int

    @property
    def name(self) -> str:
        return f"{self.variant}/{self.task}/{self.seed}"

    @property
    def max_steps(self) -> int:
        """The step budget of the cell's episodes (ticks)."""
        kind = TASKS[self.task][2]
        option = "box_steps" if self.task == "box" else "grasp_steps"
        return self.changes.get(option, DEFAULT_MAX_STEPS[kind])


def bags_digest(bags: str) -> str:
    """A digest of the contents of the bags in bags/<bags> (relative to the working directory): a
    model trained on other bags of the same name is not re-used."""
    digest = hashlib.sha1()
    for path in bag_paths([BAGS / bags]):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


def train_study_model(config: dict, bags: str) -> dict:
    """Train the model of config (Study.model_config) on bags/<bags> of the working directory (a
    worker's: the executor puts the bags there) and measure it on its demonstrations: {"model": the
    model file's bytes, "record": its training record}. ValueError when the bags are not those the
    config was keyed on."""
    if bags_digest(bags) != config["bags_digest"]:
        raise ValueError(f"the worker's bags/{bags} are not the caller's (another digest)")
    robot = RobotModel()
    demos = load_dataset(bag_paths([BAGS / bags]), robot)
    training = TrainingConfig(**training_part(config), seed=config["seed"])
    started = time.perf_counter()
    with torch_threads(config["torch_threads"]):
        if config.get("hard_negative_rounds"):
            result = train_with_hard_negatives(
                demos, robot, training, config["hard_negative_rounds"], config["rollout_steps"]
            )
        else:
            result = train(demos, robot, training)
    with tempfile.TemporaryDirectory(prefix="tric-study-") as folder:
        path = model_file.from_training(result, demos).save(pathlib.Path(folder) / "model")
        content = path.read_bytes()
    numbers = analysis.key_numbers(result.model, demos, 20)
    record = {
        "config": config,
        "train_s": time.perf_counter() - started,
        "iterations": result.iterations,
        "losses": result.losses,
        **{key: numbers[key] for key in MODEL_MEASURES},
        "selected_features": numbers["selected_features"],
        "kept_features": numbers["kept_features"],
        "file_sha1": hashlib.sha1(content).hexdigest(),
    }
    return {"model": content, "record": record}


def controller_options(changes: dict, task: str, robot: RobotModel) -> dict:
    """The keyword arguments of MotionRateController that a variant's controller settings make for
    the task (OfflineEvaluator's controller_options)."""
    options = {}
    if "hand_lead" in changes:
        lead = np.full(robot.n_joints, MAX_LEAD)
        lead[robot.hand_indices] = changes["hand_lead"]
        options["max_lead"] = lead
    if "domain_damper" in changes:
        options["domain_damper"] = changes["domain_damper"]
    contacts = contact_rules(changes, "open_box" if task == "box" else "grasp")
    if contacts is not None:
        options["contacts"] = contacts
    return options


class Study:
    """Runs a study's cells on an executor (tric_control.evaluation.executors) with jobs workers;
    models under out/models, results merged into out/study.json."""

    def __init__(self, out: pathlib.Path, jobs: int, executor):
        self.out, self.jobs, self.executor = out, jobs, executor
        self.robot = RobotModel()
        self.path = out / "study.json"
        self.results = self._read()
        self.failed: dict[str, str] = {}
        self.cleared: set[str] = set()
        self._bags_digests: dict[str, str] = {}
        (out / "models").mkdir(parents=True, exist_ok=True)

    def model_config(self, cell: Cell) -> dict:
        """Everything that makes the cell's model: its training options and seed, the bags' digest,
        PyTorch's threads and the training and analysis code's digests (and the hard negatives'
        rounds and rollout budget)."""
        bags = TASKS[cell.task][0]
        if bags not in self._bags_digests:
            self._bags_digests[bags] = bags_digest(bags)
        rounds = cell.changes.get("hard_negative_rounds", 0)
        training = "tric_control.study.hard_negatives" if rounds else "tric_learning.training.value"
        return {
            **training_part(cell.changes),
            "seed": cell.seed,
            **({"hard_negative_rounds": rounds, "rollout_steps": cell.max_steps} if rounds else {}),
            "bags_digest": self._bags_digests[bags],
            "torch_threads": TRAINING_THREADS,
            "training_code": code_digest(training),
            "analysis_code": code_digest("tric_learning.analysis"),
        }

    def cell_key(self, cell: Cell) -> dict:
        """Everything that makes the cell's row: its model's config, its controller settings, step
        budget and sets, and the digest of the episodes' code (the controller, the physics, the
        metrics and the situations)."""
        return {
            "model": self.model_config(cell),
            "controller": {k: v for k, v in cell.changes.items() if k in CONTROLLER_OPTIONS},
            "max_steps": cell.max_steps,
            "sets": list(TASKS[cell.task][1]),
            "episode_code": code_digest(
                "tric_control.evaluation.offline", "tric_sim.world.situations"
            ),
        }

    def finished_row(self, cell: Cell):
        """The cell's row in study.json if it was made with the cell's key, else None."""
        row = self.results.get("rows", {}).get(cell.name)
        return row if row is not None and row.get("key") == self.cell_key(cell) else None

    def stale_rows(self, cells) -> list:
        """["NAME (why)"] of the cells whose row in study.json was made with another key (they are
        measured again)."""
        rows = self.results.get("rows", {})
        stale = []
        for cell in cells:
            row = rows.get(cell.name)
            if isinstance(row, dict) and self.finished_row(cell) is None:
                stale.append(f"{cell.name} ({key_changes(row.get('key'), self.cell_key(cell))})")
        return stale

    def cached_model(self, config: dict, bags: str):
        """(path, record) of a model trained with config on bags, its file intact; None if
        none."""
        for key, record in self.results.get("models", {}).items():
            path = self._model_path(key)
            if (
                key.split("/")[1] == bags
                and record["config"] == config
                and path.is_file()
                and hashlib.sha1(path.read_bytes()).hexdigest() == record.get("file_sha1")
            ):
                return path, record
        return None

    def run(self, cells, on_row=None) -> dict:
        """Run every cell that has no finished row of its key: the missing models are trained first
        (at most jobs at once), then each cell's sets are measured; on_row(row) after each cell, a
        kept one too. {cell name: row} in the cells' order; a cell that failed has a row
        {"error": ...} and is listed in study.json's "failed"."""
        rows = {cell.name: self.finished_row(cell) for cell in cells}
        todo = [cell for cell in cells if rows[cell.name] is None]
        for cell in cells:
            if rows[cell.name] is not None and on_row is not None:
                on_row({**rows[cell.name], "kept": True})
        models = self._train_models(todo)
        for cell in todo:
            model = models[json.dumps(self.model_config(cell), sort_keys=True)]
            try:
                if isinstance(model, Exception):
                    raise model
                rows[cell.name] = self._measure(cell, *model)
            except Exception as error:
                rows[cell.name] = self._fail(cell, error)
            if on_row is not None:
                on_row(rows[cell.name])
        return rows

    def _train_models(self, cells) -> dict:
        """{the model config's JSON: (path, record), or the Exception its training raised} of the
        cells' models, the missing ones trained on the executor and saved as each ends."""
        models, calls, names = {}, [], []
        for cell in cells:
            config = self.model_config(cell)
            key = json.dumps(config, sort_keys=True)
            if key in models:
                continue
            bags = TASKS[cell.task][0]
            models[key] = self.cached_model(config, bags)
            if models[key] is None:
                calls.append((config, bags))
                names.append((key, f"{cell.variant}/{bags}/{cell.seed}"))
        if calls:
            print(f"training {len(calls)} models ({self.executor.kind})", flush=True)
        for k, result in self.executor.run_calls(train_study_model, calls, self.jobs):
            key, name = names[k]
            if isinstance(result, Exception):
                models[key] = result
                continue
            path = self._model_path(name)
            with atomic_path(path) as temporary:
                temporary.write_bytes(result["model"])
            self.results.setdefault("models", {})[name] = result["record"]
            self.save()
            models[key] = path, result["record"]
            print(f"trained {name} in {result['record']['train_s']:.1f} s", flush=True)
        return models

    def _measure(self, cell: Cell, path: pathlib.Path, record: dict) -> dict:
        """The cell's row: its model measured offline on the task's sets; saved."""
        row: dict = {
            "variant": cell.variant,
            "task": cell.task,
            "seed": cell.seed,
            "changes": cell.changes,
            "model": record,
            "sets": {},
        }
        options = controller_options(cell.changes, cell.task, self.robot)
        for name in TASKS[cell.task][1]:
            records = evaluate_offline(
                dataset(name),
                str(path),
                cell.max_steps,
                jobs=self.jobs,
                desc=f"{cell.variant} s{cell.seed} {name}",
                controller_options=options,
                executor=self.executor,
            )
            row["sets"][name] = measure_set(records)
        row["key"] = self.cell_key(cell)
        row["date"] = time.strftime("%Y-%m-%d %H:%M")
        self.results.setdefault("rows", {})[cell.name] = row
        self.failed.pop(cell.name, None)
        self.cleared.add(cell.name)
        self.save()
        return row

    def _fail(self, cell: Cell, error: Exception) -> dict:
        """The row of a cell that failed (kept in study.json's "failed", not as a finished row)."""
        message = f"{type(error).__name__}: {error}"
        self.failed[cell.name] = message
        self.cleared.discard(cell.name)
        self.save()
        return {"variant": cell.variant, "task": cell.task, "seed": cell.seed, "error": message}

    def _model_path(self, key: str) -> pathlib.Path:
        variant, bags, seed = key.split("/")
        return self.out / "models" / model_file_name(variant, bags, int(seed))

    def _read(self) -> dict:
        """The study file's results ({} without a file); ValueError naming the file when it is
        not a study's (read with tric_sim.tools.untrusted's limits)."""
        if not self.path.is_file():
            return {}
        results = read_data_file(self.path, "study file", json_format=True)
        parts = ("models", "rows", "failed")
        if not isinstance(results, dict) or any(
            not isinstance(results.get(part, {}), dict) for part in parts
        ):
            raise ValueError(f"study file {self.path} is not a study's results: move it away")
        return results

    def save(self):
        """Merge this study's models, rows and failed cells into the file (another study may have
        written it since)."""
        merged = self._read()
        for part in ("models", "rows"):
            merged.setdefault(part, {}).update(self.results.get(part, {}))
        failed = {**merged.get("failed", {}), **self.failed}
        merged["failed"] = {k: v for k, v in failed.items() if k not in self.cleared}
        self.results = merged
        write_json(self.path, merged)
