"""A study's candidates (tric-study): each trained once and rolled out from its demonstrations'
starts (tric_control.selection.candidates), and kept under DIR/candidates: the model file and its
training record keyed on what made the model, the rollouts keyed on the model and on what makes
an episode (a change of the controller or the episodes' code rolls the kept model out again,
without training it again). Every cell whose keys name them re-uses them: cells of one task and
group that differ only in how many candidates they choose from, how many they keep or by which
score. ROS-free."""

import functools
import hashlib
import json
import math
import pathlib

import numpy as np

from tric_control.evaluation.records import write_json
from tric_control.selection.candidates import Candidate, candidate, rolled_out
from tric_control.selection.rollouts import Rollout
from tric_control.selection.settings import CANDIDATE_THREADS
from tric_control.study.hard_negatives import train_with_hard_negatives
from tric_sim.tools.output_files import atomic_path
from tric_sim.tools.provenance import code_digest
from tric_sim.world.robot_profile import DEFAULT_ROBOT

#: The code whose digest keys a candidate's rollouts and a model's episodes: the controller, the
#: physics, the metrics and the situations.
EPISODE_CODE = ("tric_control.evaluation.offline", "tric_sim.world.situations")


def key_name(key: dict) -> str:
    """A short, stable name of a key (its hash)."""
    return hashlib.sha1(json.dumps(key, sort_keys=True).encode()).hexdigest()[:12]


class CandidateStore:
    """The candidates kept in folder: <bags>_s<seed>_<training key>.safetensors and .json (the
    model and its training record), and <bags>_s<seed>_<rollouts key>.rollouts.json; made for
    robot (a profile's name or file; the training key holds its demonstrations' digest)."""

    def __init__(self, folder: pathlib.Path, robot: str = DEFAULT_ROBOT):
        self.folder, self.robot = folder, robot
        folder.mkdir(parents=True, exist_ok=True)

    def model_path(self, bags: str, seed: int, training: dict) -> pathlib.Path:
        """Where the candidate trained as training says keeps its model file."""
        return self.folder / f"{bags}_s{seed}_{key_name(training)}.safetensors"

    def model(self, bags: str, seed: int, training: dict):
        """(model file bytes, its training record) trained as training says, intact; else None."""
        path = self.model_path(bags, seed, training)
        data = _read(path.with_suffix(".json"))
        if data is None or data.get("key") != training or not path.is_file():
            return None
        content = path.read_bytes()
        if data.get("sha1") != hashlib.sha1(content).hexdigest():
            return None
        return content, data

    def get(self, bags: str, seed: int, training: dict, rollouts: dict) -> Candidate | None:
        """The kept candidate trained as training says and rolled out as rollouts says, or
        None."""
        model = self.model(bags, seed, training)
        data = _read(self.folder / f"{bags}_s{seed}_{key_name(rollouts)}.rollouts.json")
        if model is None or data is None or data.get("key") != rollouts:
            return None
        content, record = model
        return Candidate(
            seed,
            content,
            record["record"],
            [_rollout(r) for r in data["rollouts"]],
            record["train_s"],
            data["rollout_s"],
        )

    def put(self, bags: str, training: dict, rollouts: dict, made: Candidate) -> None:
        """Keep a made candidate (its model unless kept already, and its rollouts)."""
        path = self.model_path(bags, made.seed, training)
        if self.model(bags, made.seed, training) is None:
            with atomic_path(path) as temporary:
                temporary.write_bytes(made.model)
            write_json(
                path.with_suffix(".json"),
                {
                    "key": training,
                    "sha1": hashlib.sha1(made.model).hexdigest(),
                    "record": made.record,
                    "train_s": made.train_s,
                },
            )
        write_json(
            self.folder / f"{bags}_s{made.seed}_{key_name(rollouts)}.rollouts.json",
            {
                "key": rollouts,
                "rollout_s": made.rollout_s,
                "rollouts": [rollout.to_dict() for rollout in made.rollouts],
            },
        )

    def make(self, bags: str, dataset, wanted: list, executor, jobs: int) -> dict:
        """{(seed, rollouts key name): Candidate, or the Exception its making raised} of the
        wanted candidates of bags/<bags> (dataset: its demonstrations), each wanted as
        (training key, rollouts key, TrainingConfig, max_steps, controller options, hard-negative
        rounds): the kept ones read, the others made on executor, jobs at once (one call each,
        trained unless their model is kept, then rolled out; the dataset sent once) and kept as
        each ends. A model wanted with several rollouts is trained once: its other rollouts are
        made after it."""
        made: dict = {}
        now, later, training_now = [], [], set()
        for training, rollouts, config, max_steps, options, rounds in wanted:
            name = (config.seed, key_name(rollouts))
            if name in made:
                continue
            made[name] = self.get(bags, config.seed, training, rollouts)
            if made[name] is not None:
                continue
            entry = (training, rollouts, (config, max_steps, options, rounds))
            kept = self.model(bags, config.seed, training)
            if kept is None and key_name(training) in training_now:
                later.append(entry)
                continue
            if kept is None:
                training_now.add(key_name(training))
            now.append((*entry, kept))
        self._run(bags, dataset, now, executor, jobs, made)
        again = [(*entry, self.model(bags, entry[2][0].seed, entry[0])) for entry in later]
        self._run(bags, dataset, again, executor, jobs, made)
        return made

    def _run(self, bags: str, dataset, todo: list, executor, jobs: int, made: dict) -> None:
        """Make the candidates of todo ([(training key, rollouts key, call, kept model)]) on
        executor into made, each kept as it ends."""
        if not todo:
            return
        print(f"making {len(todo)} candidates on {bags} ({executor.kind})", flush=True)
        calls = [(*call, kept, self.robot) for _, _, call, kept in todo]
        for k, result in executor.run_calls(study_candidate, calls, jobs, (dataset,)):
            training, rollouts, call, kept = todo[k]
            made[(call[0].seed, key_name(rollouts))] = result
            if isinstance(result, Exception):
                continue
            self.put(bags, training, rollouts, result)
            print(
                f"candidate {bags} s{result.seed}: "
                + ("model kept" if kept else f"trained in {result.train_s:.1f} s")
                + f", rolled out in {result.rollout_s:.1f} s",
                flush=True,
            )


def training_key(config, data_digest: str, rounds: int = 0, max_steps: int = 0) -> dict:
    """Everything that makes a candidate's model: its TrainingConfig (with its seed), its data's
    digest, PyTorch's threads and the training code's digest (and with rounds of hard negatives,
    their rounds, their rollouts' budget and the code that rolls them out)."""
    rolling = ("tric_control.study.hard_negatives",) if rounds else ()
    return {
        **config.to_dict(),
        **({"hard_negative_rounds": rounds, "rollout_steps": max_steps} if rounds else {}),
        "data_digest": data_digest,
        "torch_threads": CANDIDATE_THREADS,
        "training_code": code_digest("tric_learning.training.value", *rolling),
    }


def rollouts_key(training: dict, controller: dict, max_steps: int) -> dict:
    """Everything that makes a candidate's rollouts: its model's key, the controller's settings
    (JSON), the step budget and the digests of the rollouts' and the episodes' code."""
    return {
        "model": training,
        "controller": controller,
        "max_steps": max_steps,
        "rollout_code": code_digest("tric_control.selection.rollouts"),
        "episode_code": code_digest(*EPISODE_CODE),
    }


def study_candidate(
    dataset,
    config,
    max_steps: int,
    controller_options,
    rounds: int,
    kept=None,
    robot: str = DEFAULT_ROBOT,
) -> Candidate:
    """A study's candidate (run on its executor) of robot: the kept model (kept: (model file
    bytes, its training record), or None) rolled out again, or a model trained as the selection
    trains one, or with `rounds` rounds of hard negatives (tric_control.study.hard_negatives),
    then rolled out."""
    if kept is not None:
        content, record = kept
        return rolled_out(
            dataset,
            content,
            config.seed,
            record["record"],
            record["train_s"],
            max_steps,
            controller_options,
            robot=robot,
        )
    fit = (
        functools.partial(train_with_hard_negatives, rounds=rounds, max_steps=max_steps)
        if rounds
        else None
    )
    return candidate(dataset, config, max_steps, controller_options, fit, robot=robot)


def _read(path: pathlib.Path):
    """A kept JSON file's data, or None when it is missing or unreadable."""
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def _rollout(data: dict) -> Rollout:
    """A Rollout from its to_dict() (None back to NaN)."""
    nan = lambda value: math.nan if value is None else value  # noqa: E731
    return Rollout(
        data["demo"],
        np.array(data["q"], dtype=float),
        np.array(data["y"], dtype=float),
        nan(data["value_start"]),
        nan(data["value_end"]),
        data["steps"],
        data["outcome"],
        {k: nan(v) if k in ("grasp_cost", "lid_angle") else v for k, v in data["judged"].items()},
    )
