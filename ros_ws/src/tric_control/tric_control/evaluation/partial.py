"""The episodes of a tric-eval run judged so far, kept beside its --json result (RESULT.partial)
after each one, so that an interrupted run continues where it ended (--resume).

Each kept episode carries its key: what made it, each part as a digest or a value (KEY_PARTS): the
agent (the model file's content, not its path; or the teacher), the situation's full content, the
step budget, how it ran (through the nodes or offline) and the digest of the code that ran and
judged it (tric_sim.tools.provenance.code_digest; the controller's settings are that code's
defaults, tric-eval changes none). --resume keeps only the episodes whose key is this run's for
their situation, and names the others with what changed: the model, the situation, the budget, the
way it ran or the code. ROS-free.
"""

import hashlib
import json
import pathlib
from dataclasses import asdict

from tric_control.evaluation.records import EpisodeRecord, record_from_json, write_json
from tric_sim.tools.output_files import PARTIAL_SUFFIX
from tric_sim.tools.untrusted import read_data_file

#: The parts of an episode's key, and how a change of each is named.
KEY_PARTS = {
    "agent": "the model changed",
    "situation": "the situation changed",
    "max_steps": "the step budget changed",
    "runs": "it ran another way (through the nodes or offline, on another robot, or with other "
    "controller settings)",
    "code": "the code changed",
}
#: The partial file's format name.
FORMAT = "tric-eval partial"
#: The most dropped episodes named one by one.
NAMED_DROPS = 5


def agent_digest(model) -> str:
    """ "teacher" for None, else "sha256:<hex>" of the model file's content (read in blocks)."""
    if model is None:
        return "teacher"
    digest = hashlib.sha256()
    with open(model, "rb") as file:
        for block in iter(lambda: file.read(2**20), b""):
            digest.update(block)
    return f"sha256:{digest.hexdigest()}"


def situation_digest(situation) -> str:
    """ "sha256:<hex>" of the situation's full content (its plain data, keys sorted)."""
    text = json.dumps(situation.to_dict(), sort_keys=True)
    return f"sha256:{hashlib.sha256(text.encode()).hexdigest()}"


class PartialRecords:
    """The episodes kept in the file beside result_path (+ ".partial") by a run of agent_digest
    `agent` on situations with max_steps ticks at most (0: the task's default), run `runs`
    ("nodes" or "offline") by the code of digest code."""

    def __init__(self, result_path, agent: str, situations, max_steps: int, runs: str, code: str):
        self.path = pathlib.Path(f"{result_path}{PARTIAL_SUFFIX}")
        run = {"agent": agent, "max_steps": max_steps, "runs": runs, "code": code}
        self.keys = {s.name: {**run, "situation": situation_digest(s)} for s in situations}
        self.kept: dict[str, tuple] = {}

    def resume(self) -> tuple:
        """({situation name: EpisodeRecord} of the kept episodes whose key is this run's, [what
        was dropped: "NAME (why)"]), the file rewritten with those kept only; ({}, []) without a
        file. ValueError naming the file when it is not a partial file of tric-eval."""
        if not self.path.is_file():
            return {}, []
        data = read_data_file(self.path, "tric-eval's partial file", json_format=True)
        if not isinstance(data, dict) or not isinstance(data.get("episodes"), list):
            raise ValueError(f"{self.path} is not a partial run of tric-eval: remove it")
        dropped = []
        for episode in data["episodes"]:
            if not isinstance(episode, dict):
                raise ValueError(f"{self.path} is not a partial run of tric-eval: remove it")
            try:  # an earlier tric-eval kept the records alone, without keys
                record = record_from_json(episode.get("record", episode))
            except (TypeError, ValueError):
                raise ValueError(f"{self.path} holds a damaged episode record: remove it") from None
            why = self._mismatch(record.situation, episode.get("key"))
            if why:
                dropped.append(f"{record.situation} ({why})")
            else:
                self.kept[record.situation] = (self.keys[record.situation], record)
        if dropped:
            self._write()
        return {name: record for name, (_, record) in self.kept.items()}, dropped

    def _mismatch(self, name: str, key) -> str:
        """Why an episode kept for situation name with key is not this run's ("" if it is)."""
        if name not in self.keys:
            return "not a situation of this run"
        if not isinstance(key, dict) or set(key) != set(KEY_PARTS):
            return "kept without a key, by an earlier tric-eval"
        changed = [why for part, why in KEY_PARTS.items() if key[part] != self.keys[name][part]]
        return ", ".join(changed)

    def add(self, record: EpisodeRecord) -> None:
        """Keep record with its key, and write the file anew (atomically)."""
        self.kept[record.situation] = (self.keys[record.situation], record)
        self._write()

    def _write(self) -> None:
        episodes = [{"key": key, "record": asdict(record)} for key, record in self.kept.values()]
        write_json(self.path, {"format": FORMAT, "episodes": episodes})

    def remove(self) -> None:
        self.path.unlink(missing_ok=True)


def dropped_line(dropped: list) -> str:
    """The line naming the kept episodes a resume dropped (at most NAMED_DROPS by name)."""
    named = ", ".join(dropped[:NAMED_DROPS])
    more = f" and {len(dropped) - NAMED_DROPS} more" if len(dropped) > NAMED_DROPS else ""
    episodes = "episode" if len(dropped) == 1 else "episodes"
    return f"{len(dropped)} kept {episodes} made otherwise, run again: {named}{more}"
