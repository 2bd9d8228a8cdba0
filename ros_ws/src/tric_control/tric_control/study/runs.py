"""A study's runs (tric-study): its cells (variant x task x group seed) each choose a model as a
training does (tric_control.selection: the group's candidates trained on the task's reference bags,
rolled out from their demonstrations' starts, the best kept) and measure it offline on the task's
training and validation sets; with every_candidate, each candidate is measured on them too, for
the selection's own study (tric_control.study.selection_report). Candidates and episodes run on an
executor (tric_control.evaluation.executors: processes here, or Ray), and every finished cell is
merged into DIR/study.json at once.

All of one robot (its profile's name or file): its reference bags and its workspace's data sets.
Nothing stale is re-used: a candidate is keyed on its training options, seed, the bags' digest,
its rollouts' controller options and step budget, and the digests of the training, selection and
episode code (tric_sim.tools.provenance.code_digest), and kept under DIR/candidates
(tric_control.study.candidates); a model's measures on a set on the robot's profile (its
identity), its arrays' digest, the controller options, step budget and episode code; a finished
cell on all of these and its selection settings.
An interrupted study run again does only the cells whose key has no finished row; a cell that fails
is named with its error, and the others are kept."""

import dataclasses
import hashlib
import math
import pathlib
import time

from tric_control.episode_runner import DEFAULT_MAX_STEPS
from tric_control.evaluation.offline import evaluate_offline
from tric_control.evaluation.records import write_json
from tric_control.selection.choice import choose
from tric_control.selection.scores import score as selection_score
from tric_control.selection.settings import SCORES, SelectionConfig
from tric_control.study.candidates import (
    EPISODE_CODE,
    CandidateStore,
    key_name,
    rollouts_key,
    training_key,
)
from tric_control.study.measures import controller_options, measure_set
from tric_control.study.staleness import key_changes
from tric_control.study.variants import (
    CONTROLLER_OPTIONS,
    MODEL_MEASURES,
    TASKS,
    model_file_name,
    selection_part,
    training_part,
)
from tric_learning import analysis, model_file
from tric_learning.analysis.attraction import end_measures
from tric_learning.bags.loader import bag_paths, load_dataset
from tric_learning.model_file import tensor_digest
from tric_learning.training.value import TrainingConfig
from tric_sim.tools.provenance import code_digest
from tric_sim.tools.robot_option import reference_bags
from tric_sim.tools.untrusted import read_data_file
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.robot_profile import DEFAULT_ROBOT, load_profile
from tric_sim.world.situations import dataset


@dataclasses.dataclass(frozen=True)
class Cell:
    """One cell of a study: a variant (its name and changes) on a task, its candidates drawn from
    the group seed `seed` on."""

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

    @property
    def bags(self) -> str:
        return TASKS[self.task][0]

    @property
    def selection(self) -> SelectionConfig:
        return SelectionConfig(**selection_part(self.changes)).validate()

    @property
    def seeds(self) -> list:
        """The seeds of the cell's candidates."""
        return [self.seed + k for k in range(self.selection.candidates)]


def bags_digest(folder: pathlib.Path) -> str:
    """A digest of the contents of the bags in folder: a model trained on other bags of the same
    name is not re-used."""
    digest = hashlib.sha1()
    for path in bag_paths([folder]):
        digest.update(path.name.encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()[:12]


class Study:
    """Runs a study's cells on an executor (tric_control.evaluation.executors) with jobs workers;
    candidates under out/candidates, the chosen models under out/models, results merged into
    out/study.json (named for the robot; ValueError if it holds another robot's). every_candidate:
    measure every candidate on the task's sets too. robot: a profile's name or file; its reference
    bags (tric_sim.tools.robot_option.reference_bags, relative to the working directory) and its
    workspace's data sets."""

    def __init__(
        self,
        out: pathlib.Path,
        jobs: int,
        executor,
        every_candidate: bool = False,
        robot: str = DEFAULT_ROBOT,
    ):
        self.out, self.jobs, self.executor = out, jobs, executor
        self.every_candidate = every_candidate
        self.profile = load_profile(robot)
        self.robot = RobotModel(self.profile)
        self.path = out / "study.json"
        self.results = self._read()
        made_for = self.results.get("robot", self.profile.name)
        if made_for != self.profile.name:
            raise ValueError(
                f"{self.path} holds a study of the robot '{made_for}', not '{self.profile.name}': "
                "give another --out"
            )
        self.failed: dict[str, str] = {}
        self.cleared: set[str] = set()
        self.store = CandidateStore(out / "candidates", self.profile.spec)
        self._bags_digests: dict[str, str] = {}
        self._datasets: dict = {}
        (out / "models").mkdir(parents=True, exist_ok=True)

    def demonstrations(self, bags: str):
        """The dataset of the robot's reference bags of a set, read once."""
        if bags not in self._datasets:
            self._datasets[bags] = load_dataset(
                bag_paths([reference_bags(self.profile, bags)]), self.robot
            )
        return self._datasets[bags]

    def training_key(self, cell: Cell, seed: int) -> dict:
        """Everything that makes one of the cell's candidates' model (candidates.training_key)."""
        if cell.bags not in self._bags_digests:
            self._bags_digests[cell.bags] = bags_digest(reference_bags(self.profile, cell.bags))
        config = TrainingConfig(**training_part(cell.changes), seed=seed)
        rounds = cell.changes.get("hard_negative_rounds", 0)
        return training_key(config, self._bags_digests[cell.bags], rounds, cell.max_steps)

    def rollouts_key(self, cell: Cell, seed: int) -> dict:
        """Everything that makes a candidate's rollouts (candidates.rollouts_key)."""
        return rollouts_key(
            self.training_key(cell, seed), self.controller_key(cell), cell.max_steps
        )

    @staticmethod
    def controller_key(cell: Cell) -> dict:
        return {k: v for k, v in cell.changes.items() if k in CONTROLLER_OPTIONS}

    def cell_key(self, cell: Cell) -> dict:
        """Everything that makes the cell's row: the robot's profile, its candidates' keys, its
        selection, the sets and the analysis code."""
        return {
            "robot": self.profile.identity,
            "candidates": [self.rollouts_key(cell, seed) for seed in cell.seeds],
            "selection": cell.selection.to_dict(),
            "every_candidate": self.every_candidate,
            "sets": list(TASKS[cell.task][1]),
            "choice_code": code_digest(
                "tric_control.selection.choice",
                "tric_learning.analysis",
                "tric_learning.analysis.attraction",
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

    def run(self, cells, on_row=None) -> dict:
        """Run every cell that has no finished row of its key: the missing candidates are trained
        and rolled out first (at most jobs at once), then each cell chooses and its sets are
        measured; on_row(row) after each cell, a kept one too. {cell name: row} in the cells'
        order; a cell that failed has a row {"error": ...} and is listed in study.json's
        "failed"."""
        rows = {cell.name: self.finished_row(cell) for cell in cells}
        todo = [cell for cell in cells if rows[cell.name] is None]
        for cell in cells:
            if rows[cell.name] is not None and on_row is not None:
                on_row({**rows[cell.name], "kept": True})
        made = self._make_candidates(todo)
        for cell in todo:
            try:
                candidates = [made[self._candidate_name(cell, seed)] for seed in cell.seeds]
                failure = next((c for c in candidates if isinstance(c, Exception)), None)
                if failure is not None:
                    raise failure
                rows[cell.name] = self._measure(cell, candidates)
            except Exception as error:
                rows[cell.name] = self._fail(cell, error)
            if on_row is not None:
                on_row(rows[cell.name])
        return rows

    def _make_candidates(self, cells) -> dict:
        """{(bags, seed, rollouts key name): Candidate, or the Exception its making raised} of the
        cells' candidates (CandidateStore.make: the kept ones read, the others made)."""
        wanted: dict = {}  # bags -> [CandidateStore.make's wanted]
        for cell in cells:
            options = controller_options(cell.changes, cell.task, self.robot)
            rounds = cell.changes.get("hard_negative_rounds", 0)
            for seed in cell.seeds:
                wanted.setdefault(cell.bags, []).append(
                    (
                        self.training_key(cell, seed),
                        self.rollouts_key(cell, seed),
                        TrainingConfig(**training_part(cell.changes), seed=seed),
                        cell.max_steps,
                        options,
                        rounds,
                    )
                )
        made = {}
        for bags, todo in wanted.items():
            found = self.store.make(bags, self.demonstrations(bags), todo, self.executor, self.jobs)
            made.update({(bags, *name): value for name, value in found.items()})
        return made

    def _candidate_name(self, cell: Cell, seed: int) -> tuple:
        return cell.bags, seed, key_name(self.rollouts_key(cell, seed))

    def _measure(self, cell: Cell, candidates: list) -> dict:
        """The cell's row: its chosen model measured offline on the task's sets (and, with
        every_candidate, each candidate); saved."""
        demos = self.demonstrations(cell.bags)
        config = TrainingConfig(**training_part(cell.changes), seed=cell.seed)
        choice = choose(candidates, demos, config, cell.selection)
        path = self.out / "models" / model_file_name(cell.variant, cell.bags, cell.seed)
        choice.model.save(path)
        model = model_file.value_function(choice.model)
        numbers = {
            **analysis.key_numbers(model, demos, 20),
            **end_measures(model, demos, self.robot),
        }
        row: dict = {
            "variant": cell.variant,
            "task": cell.task,
            "seed": cell.seed,
            "changes": cell.changes,
            "model": {
                "train_s": sum(c.train_s + c.rollout_s for c in candidates),
                "chosen": choice.chosen,
                **{key: numbers[key] for key in MODEL_MEASURES},
                "selected_features": numbers["selected_features"],
                "kept_features": numbers["kept_features"],
                "tensor_digest": tensor_digest(choice.model.arrays),
            },
            "selection": choice.provenance,
            "sets": self._sets(cell, path, choice.model.arrays, f"{cell.variant} g{cell.seed}"),
        }
        if self.every_candidate:
            row["candidates"] = [self._candidate_row(cell, c, demos) for c in candidates]
        row["key"] = self.cell_key(cell)
        row["date"] = time.strftime("%Y-%m-%d %H:%M")
        self.results.setdefault("rows", {})[cell.name] = row
        self.failed.pop(cell.name, None)
        self.cleared.add(cell.name)
        self.save()
        return row

    def _candidate_row(self, cell: Cell, made, demos) -> dict:
        """A candidate's every score and its measures on the task's sets."""
        path = self.store.model_path(cell.bags, made.seed, self.training_key(cell, made.seed))
        model = model_file.value_function(model_file.from_bytes(made.model))
        scores = {name: selection_score(name, made.rollouts, demos, model) for name in SCORES}
        arrays = model_file.from_bytes(made.model).arrays
        return {
            "seed": made.seed,
            "scores": {k: (v if math.isfinite(v) else None) for k, v in scores.items()},
            "sets": self._sets(cell, path, arrays, f"{cell.variant} g{cell.seed} s{made.seed}"),
        }

    def _sets(self, cell: Cell, path: pathlib.Path, arrays: dict, label: str) -> dict:
        """{set name: measure_set} of the model file at path (its arrays) on the task's sets, each
        measured once per arrays' digest, controller options and budget (study.json's
        "evaluations")."""
        options = controller_options(cell.changes, cell.task, self.robot)
        sets = {}
        for name in TASKS[cell.task][1]:
            key = key_name(
                {
                    "robot": self.profile.identity,
                    "arrays": tensor_digest(arrays),
                    "set": name,
                    "controller": self.controller_key(cell),
                    "max_steps": cell.max_steps,
                    "episode_code": code_digest(*EPISODE_CODE),
                }
            )
            kept = self.results.get("evaluations", {}).get(key)
            if kept is None:
                records = evaluate_offline(
                    dataset(name, self.profile.workspace),
                    str(path),
                    cell.max_steps,
                    jobs=self.jobs,
                    desc=f"{label} {name}",
                    controller_options=options,
                    executor=self.executor,
                    robot=self.profile.spec,
                )
                kept = self.results.setdefault("evaluations", {})[key] = measure_set(records)
            sets[name] = kept
        return sets

    def _fail(self, cell: Cell, error: Exception) -> dict:
        """The row of a cell that failed (kept in study.json's "failed", not as a finished row)."""
        message = f"{type(error).__name__}: {error}"
        self.failed[cell.name] = message
        self.cleared.discard(cell.name)
        self.save()
        return {"variant": cell.variant, "task": cell.task, "seed": cell.seed, "error": message}

    def _read(self) -> dict:
        """The study file's results ({} without a file); ValueError naming the file when it is
        not a study's (read with tric_sim.tools.untrusted's limits)."""
        if not self.path.is_file():
            return {}
        results = read_data_file(self.path, "study file", json_format=True)
        parts = ("rows", "evaluations", "failed")
        if not isinstance(results, dict) or any(
            not isinstance(results.get(part, {}), dict) for part in parts
        ):
            raise ValueError(f"study file {self.path} is not a study's results: move it away")
        return results

    def save(self):
        """Merge this study's rows, measured sets and failed cells into the file (another study
        may have written it since)."""
        merged = self._read()
        for part in ("rows", "evaluations"):
            merged.setdefault(part, {}).update(self.results.get(part, {}))
        failed = {**merged.get("failed", {}), **self.failed}
        merged["failed"] = {k: v for k, v in failed.items() if k not in self.cleared}
        merged["robot"] = self.profile.name
        self.results = merged
        write_json(self.path, merged)
