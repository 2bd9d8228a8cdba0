"""Evaluations kept on disk (tric-experiments): an evaluation is keyed on everything that makes its
episodes (the model file's bytes or the teacher, the situations' plain data in their order, the
step budget, the controller node's parameters given and a digest of the code that runs and judges
the episodes) and its records are kept under FOLDER/<key>.json once it is complete, so that a rerun
re-uses them. While it runs, each episode judged is kept in FOLDER/<key>.json.partial as it ends,
so that a rerun after an interrupt runs only the episodes not yet judged. A changed key re-uses
nothing. ROS-free."""

import collections
import hashlib
import json
import pathlib
from dataclasses import asdict

from tric_control.evaluation.records import record_from_json, write_json
from tric_sim.tools.untrusted import read_data_file

#: The key's length in hex digits (of a SHA-256).
KEY_LENGTH = 16


def evaluation_key(model, situations, max_steps: int, code: str, controller=None) -> tuple:
    """(key, what it is made of) of an evaluation of model (a model file's path, or None: the
    teacher) on situations with max_steps ticks at most (0: the task's default), the controller
    node's parameters controller (a dict; None: its defaults), run and judged by the code of
    digest code (tric_sim.tools.provenance.code_digest)."""
    agent = "teacher"
    if model is not None:
        agent = "sha256:" + hashlib.sha256(pathlib.Path(model).read_bytes()).hexdigest()
    made_of = {
        "agent": agent,
        "situations": [situation.to_dict() for situation in situations],
        "max_steps": max_steps,
        "controller": controller or {},
        "code": code,
    }
    text = json.dumps(made_of, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:KEY_LENGTH], made_of


def kept_evaluation(
    folder, situations, model, max_steps: int, code: str, run, controller=None
) -> list:
    """The EpisodeRecords of model (None: the teacher) on situations, in their order: those kept in
    folder/<key>.json (evaluation_key) when that evaluation is complete; else run(situations,
    on_record), which evaluates and returns their records and calls on_record(record) as each
    episode ends, on the situations not yet kept in folder/<key>.json.partial. Situations of one
    name (fig9's repeated positions) are run in separate calls, so that each episode kept is known
    by its name; controller: the controller node's parameters given (evaluation_key's).
    ValueError for a kept file that is not this evaluation's."""
    key, made_of = evaluation_key(model, situations, max_steps, code, controller)
    folder = pathlib.Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    path, partial = folder / f"{key}.json", folder / f"{key}.json.partial"
    names = [situation.name for situation in situations]
    if path.is_file():
        kept = _read(path, key, names)
        if len(kept) != len(names):
            raise ValueError(f"{path} lacks episodes of its evaluation: remove it")
        print(f"re-used {len(kept)} episodes kept in {path}", flush=True)
        return [kept[index] for index in range(len(situations))]
    kept = _read(partial, key, names) if partial.is_file() else {}
    if kept:
        print(f"{len(kept)} episodes kept in {partial}", flush=True)
    for indices in _rounds(names, kept):
        by_name = {names[index]: index for index in indices}

        def keep(record, by_name=by_name):
            kept[by_name[record.situation]] = record
            _write(partial, key, made_of, kept)

        run([situations[index] for index in indices], keep)
    _write(path, key, made_of, kept)
    partial.unlink(missing_ok=True)
    return [kept[index] for index in range(len(situations))]


def _rounds(names, kept: dict) -> list:
    """The indices of the situations not yet kept, in rounds within which no name repeats."""
    rounds: list[list[int]] = []
    seen: collections.Counter[str] = collections.Counter()
    for index, name in enumerate(names):
        if index not in kept:
            if len(rounds) <= seen[name]:
                rounds.append([])
            rounds[seen[name]].append(index)
            seen[name] += 1
    return rounds


def _write(path: pathlib.Path, key: str, made_of: dict, kept: dict) -> None:
    """Write the records kept ({situation index: EpisodeRecord}) to path, atomically, with the key
    and what it is made of."""
    episodes = [{"index": index, **asdict(kept[index])} for index in sorted(kept)]
    write_json(path, {"key": key, "made_of": made_of, "episodes": episodes})


def _read(path: pathlib.Path, key: str, names) -> dict:
    """{situation index: EpisodeRecord} of a file _write wrote for key; ValueError naming the file
    when it is not one, or its episodes are not of these situations."""
    data = read_data_file(path, "kept evaluation", json_format=True)
    if not isinstance(data, dict) or data.get("key") != key or "episodes" not in data:
        raise ValueError(f"{path} is not an evaluation kept by tric-experiments: remove it")
    kept = {}
    for episode in data["episodes"]:
        index = episode.pop("index", None) if isinstance(episode, dict) else None
        record = record_from_json(episode)
        if (
            not isinstance(index, int)
            or not 0 <= index < len(names)
            or (record.situation != names[index])
        ):
            raise ValueError(f"{path} holds an episode of another situation: remove it")
        kept[index] = record
    return kept
