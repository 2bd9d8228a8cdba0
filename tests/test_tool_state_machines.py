"""The tools' output discipline as state machines (hypothesis, 20 examples each, drawn the same way
on every run): tric-eval, tric-train, tric-record and tric-study run again and again on one
output, with their inputs changed between runs, interrupted (SIGINT or SIGTERM, as
run_interruptible turns them into exceptions in-process) at a drawn moment, or with a file written
meanwhile by another program; after each run the outputs are as the tool promises and nothing
stale, unfinished, temporary or locked is left.

These test the tools' own code (claims, checks, partial results, keys, final moves); their heavy
work (episodes, trainings, demonstrations through the nodes) is replaced by quick stand-ins made
for each machine, so that many runs cost seconds. The real work is tested elsewhere
(test_interrupts.py, test_eval_cli.py, test_study_resume.py)."""

import contextlib
import dataclasses
import hashlib
import io
import json
import os
import pathlib
import shutil
import tempfile

import numpy as np
from demo_bags import sphere, write_demo_bag
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, invariant, precondition, rule

from conftest import REFERENCE_BAGS
from tric_control import evaluate_cli, train_cli
from tric_control.evaluation import offline
from tric_control.evaluation.records import EpisodeRecord, unjudged_fields
from tric_control.selection.candidates import Candidate
from tric_control.selection.rollouts import Rollout
from tric_control.study import candidates as study_candidates
from tric_control.study import cli as study_cli
from tric_control.study import runs as study_runs
from tric_learning import demonstrations, model_file, record_cli
from tric_learning.model_file import ModelFile
from tric_learning.training import dpl
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.tools import claims, output_files
from tric_sim.tools.file_names import safe_stem
from tric_sim.tools.interrupts import Terminated
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation_files import save_situations
from tric_sim.world.situations import dataset

MACHINE_SETTINGS = settings(
    max_examples=20,
    stateful_step_count=10,
    deadline=None,
    derandomize=True,
    suppress_health_check=list(HealthCheck),
)
#: How a run ends early: SIGINT or SIGTERM (the exceptions they raise in-process), or not at all.
ENDINGS = st.sampled_from([KeyboardInterrupt, Terminated, None])
STATUS = {KeyboardInterrupt: 130, Terminated: 143}


def leftovers(folder: pathlib.Path) -> list:
    """Temporary files of atomic writes and lock files of claims under folder."""
    return sorted(
        str(path.relative_to(folder))
        for path in folder.rglob("*")
        if path.name.startswith(".tric-") or path.name.endswith(".lock")
    )


def digest_number(*parts) -> float:
    """A number in [0, 1) that only the parts decide."""
    text = json.dumps([str(part) for part in parts])
    return int(hashlib.sha256(text.encode()).hexdigest()[:8], 16) / 2**32


class Machine(RuleBasedStateMachine):
    """A folder of its own per example, module attributes patched for it and restored at its
    end, and what every tool leaves: no temporary file, no lock file, no claim held."""

    def __init__(self):
        super().__init__()
        self.folder = pathlib.Path(tempfile.mkdtemp(prefix="tric-machine-"))
        self._patched: list = []

    def patch(self, owner, name: str, replacement) -> None:
        self._patched.append((owner, name, getattr(owner, name)))
        setattr(owner, name, replacement)

    @invariant()
    def nothing_temporary_or_locked_is_left(self):
        assert leftovers(self.folder) == [] and claims.held_locks() == []

    def teardown(self):
        for owner, name, original in reversed(self._patched):
            setattr(owner, name, original)
        shutil.rmtree(self.folder, ignore_errors=True)


class EvaluationRuns(Machine):
    """tric-eval --json on a model file and a situations file that change between runs, resumed
    or not, interrupted after a drawn number of episodes or with the result written meanwhile by
    another program: a finished result holds exactly the episodes of the inputs as they are (never
    a kept episode of a replaced model, a moved situation or another budget), and a resume runs
    exactly the episodes not kept with their key."""

    def __init__(self):
        super().__init__()
        self.model, self.situations = self.folder / "m.safetensors", self.folder / "s.yaml"
        self.out, self.partial = self.folder / "r.json", self.folder / "r.json.partial"
        self.model.write_bytes(b"model 0")
        self.chosen = list(dataset("sphere_test")[:3])
        save_situations(self.situations, self.chosen)
        self.budget, self.stop, self.ending, self.foreign, self.ran = 20, None, None, False, []
        self.patch(offline, "evaluate_offline", self.episodes)

    def truth(self, situation, budget=None) -> float:
        """The grasp cost the stand-in gives situation with the model and budget as they are."""
        return digest_number(self.model.read_bytes(), situation.to_dict(), budget or self.budget)

    def episodes(self, situations, model, max_steps, snapshots=None, on_record=None, **_):
        """The stand-in of the offline episodes: a cost decided by what makes the episode."""
        records = []
        if self.foreign:
            self.out.write_text("another program's")
        for situation in situations:
            self.ran.append(situation.name)
            record = EpisodeRecord(
                **unjudged_fields(situation, "tric"), wall_time_s=0.0, outcome="step_budget"
            )
            record.grasp_cost, record.steps = self.truth(situation, max_steps), max_steps
            on_record(record)
            records.append(record)
            if self.stop is not None and len(self.ran) > self.stop:
                raise self.ending()
        return records

    def change(self, what: str, k: int) -> None:
        """Between runs: the model file replaced by another (same path), situation k moved by
        15 cm in the file, or the step budget changed."""
        if what == "model":
            self.model.write_bytes(f"model {k} {self.model.read_bytes()!r}".encode()[:64])
        elif what == "situation":
            x, y, z = self.chosen[k].object_position
            moved = (x, y + (0.15 if y < 0.15 else -0.15), z)
            self.chosen[k] = dataclasses.replace(self.chosen[k], object_position=moved)
            save_situations(self.situations, self.chosen)
        elif what == "budget":
            self.budget = 50 - self.budget

    @rule(
        what=st.sampled_from(["model", "situation", "budget", "nothing"]),
        k=st.integers(0, 2),
        resume=st.sampled_from([True, False]),
        overwrite=st.sampled_from([False, True]),
        stop=st.sampled_from([0, 1, 2, None]),
        ending=ENDINGS,
        foreign=st.sampled_from([False, True]),
    )
    def evaluate(self, what, k, resume, overwrite, stop, ending, foreign):
        self.change(what, k)
        kept = self._kept() if resume else {}
        refused = (self.out.exists() and not overwrite) or (
            self.partial.exists() and not resume and not overwrite
        )
        before = self.out.read_bytes() if self.out.exists() else None
        todo = [s.name for s in self.chosen if s.name not in kept]
        interrupted = ending is not None and stop is not None and stop < len(todo) and not refused
        self.stop, self.ending = (stop, ending) if interrupted else (None, None)
        self.foreign, self.ran = foreign and bool(todo) and not refused, []
        arguments = ["--model", str(self.model), "--situations-file", str(self.situations)]
        arguments += ["--offline", "--json", str(self.out), "--max-steps", str(self.budget)]
        arguments += ["--resume"] * resume + ["--overwrite"] * overwrite
        status = evaluate_cli.main(arguments)
        if refused:
            assert status == 2 and self.ran == []
            assert (self.out.read_bytes() if self.out.exists() else None) == before
        elif interrupted:
            assert status == STATUS[ending] and self.ran == todo[: stop + 1]
            assert set(self._kept()) == set(kept) | set(todo[: stop + 1])
        elif self.foreign and not overwrite:
            assert status == 2 and self.ran == todo
            assert self.out.read_text() == "another program's"
            self._check_result(self.folder / "r.new.json")
            (self.folder / "r.new.json").unlink()
        else:
            assert status == 0 and self.ran == todo and not self.partial.exists()
            self._check_result(self.out)

    def _kept(self) -> dict:
        """{situation name: grasp cost} of the kept episodes still made as the inputs are."""
        if not self.partial.exists():
            return {}
        data = json.loads(self.partial.read_text())
        truths = {s.name: self.truth(s) for s in self.chosen}
        return {
            e["record"]["situation"]: e["record"]["grasp_cost"]
            for e in data["episodes"]
            if truths.get(e["record"]["situation"]) == e["record"]["grasp_cost"]
        }

    def _check_result(self, path: pathlib.Path) -> None:
        episodes = json.loads(path.read_text())["episodes"]
        assert [e["situation"] for e in episodes] == [s.name for s in self.chosen]
        assert [e["grasp_cost"] for e in episodes] == [self.truth(s) for s in self.chosen]

    @rule()
    def remove_the_result(self):
        self.out.unlink(missing_ok=True)


EvaluationRuns.TestCase.settings = MACHINE_SETTINGS
test_tric_eval_runs_again_and_again = EvaluationRuns.TestCase


_TRAINING: dict = {}
#: A tiny DPL training: its options on tric-train's command line.
TINY = ["--kind", "dpl_joint", "--iterations", "2", "--hidden-units", "4", "--quiet"]


def tiny_training() -> tuple:
    """(folder of two hand-made demonstration bags, a real DPL training result on them), made
    once. DPL's path through tric-train (training.dpl.train_dpl_from_bags, from_bags.train_on_bags)
    claims, checks and writes its model as TRIC's does."""
    if not _TRAINING:
        folder = pathlib.Path(tempfile.mkdtemp(prefix="tric-machine-bags-"))
        robot = RobotModel()
        for k in range(2):
            write_demo_bag(folder / f"demo_{k}.mcap", robot, sphere(f"demo_{k}"))
        out = folder.parent / f"{folder.name}.safetensors"
        captured = {}
        train = dpl.train_dpl

        def capture(*args, **kwargs):
            captured["result"] = train(*args, **kwargs)
            return captured["result"]

        dpl.train_dpl = capture
        try:
            assert train_cli.main([str(folder), "--out", str(out), *TINY]) == 0
        finally:
            dpl.train_dpl = train
        out.unlink()
        _TRAINING.update(bags=folder, result=captured["result"])
    return _TRAINING["bags"], _TRAINING["result"]


class TrainingRuns(Machine):
    """tric-train --out one model path, again and again with other seeds: the path exists unless
    --overwrite is refused before loading; a disk without the model's room is refused before the
    training; an interrupted training leaves the earlier model; a model file written meanwhile by
    another program is kept unless --overwrite (the new model goes beside it); a finished model
    is the last run's, readable by all (0644 under umask 0022)."""

    def __init__(self):
        super().__init__()
        self.bags, self.result = tiny_training()
        self.out = self.folder / "m.safetensors"
        self.ending, self.foreign, self.fits = None, False, 0
        self.patch(dpl, "train_dpl", self.fit)
        self.umask = os.umask(0o022)

    def fit(self, dataset, robot, config, kind, report=None):
        """The stand-in of the training: the real tiny result, with this run's settings."""
        self.fits += 1
        if self.foreign:
            self.out.write_bytes(b"another program's")
        if self.ending:
            raise self.ending()
        return dataclasses.replace(self.result, config=config)

    @rule(
        seed=st.integers(0, 3),
        overwrite=st.sampled_from([True, False]),
        ending=st.sampled_from([None, KeyboardInterrupt, Terminated]),
        foreign=st.sampled_from([True, False]),
        full_disk=st.sampled_from([False, True]),
    )
    def train(self, seed, overwrite, ending, foreign, full_disk):
        before = self.out.read_bytes() if self.out.exists() else None
        refused = before is not None and not overwrite
        self.ending, self.foreign, self.fits = ending, foreign, 0
        if full_disk:
            usage = output_files.shutil.disk_usage
            self.patch(
                output_files.shutil, "disk_usage", lambda path: usage(path)._replace(free=20_000)
            )
        arguments = [str(self.bags), "--out", str(self.out), "--seed", str(seed), *TINY]
        try:
            status = train_cli.main(arguments + ["--overwrite"] * overwrite)
        finally:
            if full_disk:
                owner, name, original = self._patched.pop()
                setattr(owner, name, original)
        if refused or full_disk:
            assert status == 2 and self.fits == 0
            assert (self.out.read_bytes() if self.out.exists() else None) == before
            return
        if ending:
            assert status == STATUS[ending]
            assert (self.out.read_bytes() if self.out.exists() else None) == (
                b"another program's" if foreign else before
            )
            return
        if foreign and not overwrite:
            assert status == 2 and self.out.read_bytes() == b"another program's"
            kept = self.folder / "m.new.safetensors"
            assert ModelFile.load(kept).info["hyperparameters"]["seed"] == seed
            kept.unlink()
            return
        assert status == 0
        assert ModelFile.load(self.out).info["hyperparameters"]["seed"] == seed
        assert self.out.stat().st_mode & 0o777 == 0o644

    @rule()
    def remove_the_model(self):
        self.out.unlink(missing_ok=True)

    def teardown(self):
        os.umask(self.umask)
        super().teardown()


TrainingRuns.TestCase.settings = MACHINE_SETTINGS
test_tric_train_runs_again_and_again = TrainingRuns.TestCase


#: Situation names to record: two map to one bag name ("grasp_a"), two differ in case only
#: (two files here, where the file system tells case apart), "x" names the input when the
#: situations file is put in the folder as x.mcap.
NAMES = ["grasp a", "grasp_a", "Grasp_c", "grasp_c", "x", "y"]


class _Done:
    """A demonstration's result as tric-record's table prints it: a success."""

    success, message = True, ""

    class metrics:
        success, grasp_cost, lift_passed, lid_angle = True, 0.0, True, 0.0


class RecordingRuns(Machine):
    """tric-record into one folder with drawn situations: names that map to one bag, or to the
    situations file itself, and a folder with files without --overwrite, are refused before any
    demonstration and change nothing; a run interrupted after a drawn number of demonstrations
    keeps the finished bags; every finished bag is whole, the input is never written over."""

    def __init__(self):
        super().__init__()
        self.out = self.folder / "bags"
        self.stop, self.ending, self.made = None, None, []
        self.patch(demonstrations, "demonstrate_all", self.demonstrate)

    def demonstrate(self, situations, out, period, duration, **_):
        """The stand-in of the nodes: each bag written as .part, then renamed when finished."""
        rows = []
        for situation in situations:
            part = out / f"{safe_stem(situation.name)}.mcap.part"
            part.write_text("unfinished")
            self.made.append(situation.name)
            if self.stop is not None and len(self.made) > self.stop:
                raise self.ending()
            os.replace(part, part.with_suffix(""))
            part.with_suffix("").write_text(f"bag of {situation.name}")
            rows.append((situation, _Done(), part.with_suffix("")))
        return rows

    @rule(
        names=st.lists(st.sampled_from(NAMES), min_size=1, max_size=4, unique=True),
        input_inside=st.sampled_from([True, False]),
        overwrite=st.sampled_from([True, False]),
        stop=st.sampled_from([1, 0, None]),
        ending=ENDINGS,
    )
    def record(self, names, input_inside, overwrite, stop, ending):
        source = self.out / "x.mcap" if input_inside else self.folder / "s.yaml"
        base = dataset("sphere_train")
        save_situations(source, [dataclasses.replace(base[k], name=n) for k, n in enumerate(names)])
        before = {p.name: p.read_bytes() for p in self.out.iterdir()} if self.out.exists() else {}
        stems = [safe_stem(name) for name in names]
        refused = (
            len(set(stems)) < len(stems)
            or (input_inside and "x" in stems)
            or (bool(before) and not overwrite)
        )
        interrupted = ending is not None and stop is not None and stop < len(names) and not refused
        self.stop, self.ending = (stop, ending) if interrupted else (None, None)
        self.made = []
        arguments = ["--situations-file", str(source), "--out", str(self.out)]
        status = record_cli.main(arguments + ["--overwrite"] * overwrite)
        after = {p.name: p.read_bytes() for p in self.out.iterdir()} if self.out.exists() else {}
        if refused:
            assert status == 2 and self.made == [] and after == before
        elif interrupted:
            assert status == STATUS[ending] and self.made == names[: stop + 1]
            for name in names[:stop]:
                assert after[f"{safe_stem(name)}.mcap"] == f"bag of {name}".encode()
        else:
            assert status == 0 and self.made == names
            for name in names:
                assert after[f"{safe_stem(name)}.mcap"] == f"bag of {name}".encode()
        assert source.read_text().startswith("situations:")  # never written over
        source.unlink()

    @invariant()
    def every_bag_is_whole(self):
        for bag in self.out.glob("*.mcap") if self.out.exists() else ():
            assert bag.read_text().startswith("bag of ")

    @precondition(lambda self: self.out.exists())
    @rule()
    def remove_the_unfinished(self):
        for part in self.out.glob("*.part"):
            part.unlink()


RecordingRuns.TestCase.settings = MACHINE_SETTINGS
test_tric_record_runs_again_and_again = RecordingRuns.TestCase


#: Study variants to draw from: two trainings and a controller setting of the first's models.
VARIANTS = {
    "a": "a=candidates=1,max_iterations=2",
    "b": "b=candidates=1,max_iterations=3",
    "a_short": "a_short=candidates=1,max_iterations=2,grasp_steps=30",
}


class StudyRuns(Machine):
    """tric-study into one folder with drawn variants and seeds, the episodes' code changed between
    runs, interrupted in a drawn cell's episodes: a finished study holds a row of every cell made
    with the cell's key; a rerun measures exactly the cells without one (naming the rows it
    measures again, made otherwise) and keeps the others; a damaged study.json is named."""

    def __init__(self):
        super().__init__()
        self.out = self.folder / "study"
        self.code, self.rows, self.measured = 0, {}, []
        self.stop, self.ending = None, None
        self.cwd = os.getcwd()
        os.chdir(REFERENCE_BAGS.parent)  # tric-study reads bags/ of the working directory
        self.patch(study_runs, "code_digest", lambda *modules: f"code {self.code}")
        self.patch(study_candidates, "code_digest", lambda *modules: f"code {self.code}")
        self.patch(study_candidates, "study_candidate", self.candidate)
        ends = {"end_samples_above": 1.0, "end_gradient_ratio": 0.0}
        self.patch(study_runs, "end_measures", lambda *_: ends)
        self.patch(study_runs, "evaluate_offline", self.episodes)

    @staticmethod
    def candidate(dataset, config, max_steps, options, rounds, kept=None, robot=None) -> Candidate:
        """The stand-in of a study's candidate: a value function of weights decided by the config,
        on the demonstrations' scaling, and rollouts that end where the demonstrations end."""
        rng = np.random.default_rng(int(digest_number(config.to_dict()) * 2**32))
        scaling = Scaling.fit(np.concatenate([demo.y for demo in dataset.demos]), 0.995)
        size = len(scaling.kept)
        function = ValueFunction(
            scaling, rng.normal(0, 1, (2, size)), rng.normal(0, 1, 2), rng.normal(0, 1, size)
        )
        info = {
            "hyperparameters": config.to_dict(),
            "losses": {"total": 0.0, "n": 0.0, "g": 0.0, "w": 0.0},
            "delta": 0.01,
            "rho": 1.0,
        }
        content = (
            model_file.ModelFile(
                "tric", dataset.definition, model_file.value_function_arrays(function), info
            )
            .save(pathlib.Path(tempfile.mkdtemp()) / "m.safetensors")
            .read_bytes()
        )
        rollouts = [
            Rollout(demo.name, demo.q[-1], demo.y[-1], 1.0, 0.0, max_steps, "step_budget", {})
            for demo in dataset.demos
        ]
        return Candidate(config.seed, content, {"losses": info["losses"]}, rollouts, 0.0, 0.0)

    def episodes(self, situations, model, max_steps, desc="", **_):
        """The stand-in of a set's offline episodes."""
        self.measured.append(desc)
        if self.stop is not None and len(self.measured) > self.stop:
            raise self.ending()
        content = pathlib.Path(model).read_bytes()
        records = []
        for situation in situations:
            record = EpisodeRecord(
                **unjudged_fields(situation, "tric"), wall_time_s=0.0, outcome="converged"
            )
            record.grasp_cost = digest_number(content, situation.name, max_steps)
            records.append(record)
        return records

    @rule(
        variants=st.lists(st.sampled_from(list(VARIANTS)), min_size=1, max_size=2, unique=True),
        seeds=st.sampled_from([[0, 1], [0]]),
        stop=st.sampled_from([1, 0, None]),
        ending=ENDINGS,
    )
    def study(self, variants, seeds, stop, ending):
        cells = [(variant, seed) for variant in variants for seed in seeds]
        todo = [cell for cell in cells if self.rows.get(cell) != self.code]
        stale = [cell for cell in todo if cell in self.rows]
        interrupted = ending is not None and stop is not None and stop < len(todo)
        self.stop, self.ending = (stop, ending) if interrupted else (None, None)
        self.measured = []
        arguments = [argument for v in variants for argument in ("--variant", VARIANTS[v])]
        arguments += ["--tasks", "sphere", "--seeds", *map(str, seeds), "--jobs", "1"]
        arguments += ["--executor", "processes", "--out", str(self.out)]
        errors = io.StringIO()
        with contextlib.redirect_stderr(errors), contextlib.redirect_stdout(io.StringIO()):
            status = study_cli.main(arguments)
        expected = [f"{variant} g{seed} sphere_val" for variant, seed in todo]
        if interrupted:
            assert status == STATUS[ending] and self.measured == expected[: stop + 1]
        else:
            assert status == 0 and self.measured == expected
        assert ("made otherwise, measured again" in errors.getvalue()) == bool(stale)
        for cell in todo[:stop] if interrupted else todo:
            self.rows[cell] = self.code
        if self.rows:
            rows = json.loads((self.out / "study.json").read_text())["rows"]
            assert {
                (row["variant"], row["seed"]): row["key"]["candidates"][0]["episode_code"]
                for row in rows.values()
            } == {cell: f"code {code}" for cell, code in self.rows.items()}

    @rule()
    def change_the_code(self):
        self.code += 1

    @precondition(lambda self: (self.out / "study.json").exists())
    @rule()
    def damage_the_study_file(self):
        """Cut in half: named, one line, exit 2; put back as it was."""
        path = self.out / "study.json"
        content = path.read_bytes()
        path.write_bytes(content[: len(content) // 2])
        arguments = ["--variant", VARIANTS["a"], "--tasks", "sphere", "--seeds", "0", "--jobs"]
        arguments += ["1", "--executor", "processes", "--out", str(self.out)]
        errors = io.StringIO()
        with contextlib.redirect_stderr(errors):
            assert study_cli.main(arguments) == 2
        assert errors.getvalue().startswith(f"tric-study: study file {path} is not valid JSON")
        assert errors.getvalue().count("\n") == 1
        path.write_bytes(content)

    def teardown(self):
        os.chdir(self.cwd)
        super().teardown()


StudyRuns.TestCase.settings = MACHINE_SETTINGS
test_tric_study_runs_again_and_again = StudyRuns.TestCase
