"""tric-experiments' kept evaluations (tric_control.evaluation.kept): an evaluation interrupted
after some episodes runs only the others when run again and gives the records of an uninterrupted
run; a complete one is re-used; a change of the model file, the situations, the step budget or the
code re-uses nothing; repeated situation names (fig9) keep their own episodes."""

import dataclasses
import json

import pytest

from tric_control.evaluation.kept import evaluation_key, kept_evaluation
from tric_control.evaluation.records import EpisodeRecord, unjudged_fields
from tric_sim.world import situations

CODE = "code-digest"


class StandIn:
    """Stands in for the nodes' evaluation: a record per situation that depends on the model file,
    the situation and max_steps; it records which situations it ran, and raises KeyboardInterrupt
    (a Ctrl-C) once it has ended `interrupt_after` episodes."""

    def __init__(self, model, max_steps, interrupt_after=None):
        self.model, self.max_steps, self.interrupt_after = model, max_steps, interrupt_after
        self.ran = []

    def __call__(self, chosen, on_record):
        records = []
        for situation in reversed(chosen):  # workers end in any order
            if self.interrupt_after is not None and len(self.ran) == self.interrupt_after:
                raise KeyboardInterrupt
            self.ran.append(situation.name)
            records.append(self.record(situation))
            on_record(records[-1])
        return records[::-1]

    def record(self, situation):
        agent = "teacher" if self.model is None else self.model.read_text()
        return EpisodeRecord(
            **{
                **unjudged_fields(situation, agent),
                "grasp_cost": situation.object_position[0] * 0.1,
                "steps": self.max_steps or 500,
            },
            wall_time_s=0.5,
            outcome="step_budget",
        )


def spheres(count, shift=0.0):
    return [situations.sphere(f"s{k}", (0.5 + 0.01 * k + shift, 0.0, 0.05)) for k in range(count)]


def test_an_interrupted_evaluation_continues_with_the_episodes_not_judged(tmp_path):
    model = tmp_path / "model.safetensors"
    model.write_text("weights A")
    tests = spheres(6)
    whole = kept_evaluation(tmp_path / "once", tests, model, 0, CODE, StandIn(model, 0))

    folder = tmp_path / "episodes"
    interrupted = StandIn(model, 0, interrupt_after=4)
    with pytest.raises(KeyboardInterrupt):
        kept_evaluation(folder, tests, model, 0, CODE, interrupted)
    assert interrupted.ran == ["s5", "s4", "s3", "s2"]
    key, _ = evaluation_key(model, tests, 0, CODE)
    assert sorted(p.name for p in folder.iterdir()) == [f"{key}.json.partial"]

    again = StandIn(model, 0)
    resumed = kept_evaluation(folder, tests, model, 0, CODE, again)
    assert again.ran == ["s1", "s0"]
    assert resumed == whole
    assert sorted(p.name for p in folder.iterdir()) == [f"{key}.json"]
    stored = json.loads((folder / f"{key}.json").read_text())
    assert stored["made_of"]["situations"] == [s.to_dict() for s in tests]

    unused = StandIn(model, 0)
    assert kept_evaluation(folder, tests, model, 0, CODE, unused) == whole
    assert unused.ran == []  # complete: re-used


def test_a_changed_evaluation_re_uses_nothing(tmp_path):
    model = tmp_path / "model.safetensors"
    model.write_text("weights A")
    tests = spheres(3)
    folder = tmp_path / "episodes"
    kept_evaluation(folder, tests, model, 0, CODE, StandIn(model, 0))
    other_model = tmp_path / "other.safetensors"
    other_model.write_text("weights B")
    moved = [dataclasses.replace(tests[0], object_position=(0.6, 0.0, 0.05))] + tests[1:]
    changes = {
        "model file": (tests, other_model, 0, CODE),
        "teacher": (tests, None, 0, CODE),
        "situation": (moved, model, 0, CODE),
        "order": (tests[::-1], model, 0, CODE),
        "max_steps": (tests, model, 300, CODE),
        "code": (tests, model, 0, "another digest"),
    }
    for what, (chosen, agent, max_steps, code) in changes.items():
        evaluation = StandIn(agent, max_steps)
        records = kept_evaluation(folder, chosen, agent, max_steps, code, evaluation)
        assert sorted(evaluation.ran) == sorted(s.name for s in chosen), what
        assert records == [evaluation.record(s) for s in chosen], what
    # the same model file rewritten with other weights is another model
    model.write_text("weights C")
    evaluation = StandIn(model, 0)
    kept_evaluation(folder, tests, model, 0, CODE, evaluation)
    assert len(evaluation.ran) == 3


def test_situations_of_one_name_keep_their_own_episodes(tmp_path):
    """fig9 repeats training positions under one name, each shifted otherwise: an interrupt
    between them resumes each at its own place."""
    tests = spheres(3) + spheres(2, shift=0.05)  # s0, s1, s2, s0, s1
    whole = kept_evaluation(tmp_path / "once", tests, None, 0, CODE, StandIn(None, 0))
    assert whole[3].grasp_cost != whole[0].grasp_cost

    folder = tmp_path / "episodes"
    interrupted = StandIn(None, 0, interrupt_after=4)
    with pytest.raises(KeyboardInterrupt):
        kept_evaluation(folder, tests, None, 0, CODE, interrupted)
    again = StandIn(None, 0)
    assert kept_evaluation(folder, tests, None, 0, CODE, again) == whole
    assert len(interrupted.ran) + len(again.ran) == len(tests)


def test_a_kept_file_of_another_evaluation_is_refused(tmp_path):
    tests = spheres(2)
    key, _ = evaluation_key(None, tests, 0, CODE)
    folder = tmp_path / "episodes"
    folder.mkdir()
    (folder / f"{key}.json.partial").write_text(json.dumps({"key": "0" * 16, "episodes": []}))
    with pytest.raises(ValueError, match="is not an evaluation kept by tric-experiments"):
        kept_evaluation(folder, tests, None, 0, CODE, StandIn(None, 0))
    (folder / f"{key}.json.partial").unlink()
    episode = {"index": 0, **dataclasses.asdict(StandIn(None, 0).record(tests[1]))}
    (folder / f"{key}.json").write_text(json.dumps({"key": key, "episodes": [episode]}))
    with pytest.raises(ValueError, match="holds an episode of another situation"):
        kept_evaluation(folder, tests, None, 0, CODE, StandIn(None, 0))


def test_the_experiments_runner_keeps_its_evaluations_under_out_episodes(tmp_path, monkeypatch):
    from tric_control.experiments import runner as runner_module

    ran = []

    def nodes_stand_in(chosen, model, max_steps, on_record=None, **options):
        ran.append([s.name for s in chosen])
        return StandIn(model, max_steps)(chosen, on_record)

    monkeypatch.setattr(runner_module, "evaluate", nodes_stand_in)
    runner = runner_module.Runner(tmp_path / "results")
    tests = spheres(3)
    first = runner.evaluate(tests, None, "teacher")
    assert runner.evaluate(tests, None, "teacher, again") == first
    assert ran == [["s0", "s1", "s2"]]
    assert len(list((tmp_path / "results" / "episodes").glob("*.json"))) == 1
    runner.evaluate(tests, None, "teacher, 300 steps", max_steps=300)
    assert ran[1:] == [["s0", "s1", "s2"]]


def test_a_sparse_kept_file_is_refused_before_it_is_read_whole(tmp_path):
    tests = spheres(2)
    key, _ = evaluation_key(None, tests, 0, CODE)
    folder = tmp_path / "episodes"
    folder.mkdir()
    with open(folder / f"{key}.json.partial", "wb") as file:
        file.truncate(300 * 2**20)
    with pytest.raises(ValueError, match="is larger than 16 MiB"):
        kept_evaluation(folder, tests, None, 0, CODE, StandIn(None, 0))


def test_the_experiments_runner_of_another_robot_uses_its_bags_data_sets_and_nodes(
    tmp_path, monkeypatch
):
    """tric-experiments --robot panda: the Panda's reference bags (bags/panda/<set>), its data
    sets in its workspace, its candidates and its nodes (the robot parameter of the evaluation)."""
    from tric_control.experiments import runner as runner_module

    asked = []

    def nodes_stand_in(chosen, model, max_steps, on_record=None, robot=None, **options):
        asked.append(robot)
        return StandIn(model, max_steps)(chosen, on_record)

    monkeypatch.setattr(runner_module, "evaluate", nodes_stand_in)
    runner = runner_module.Runner(tmp_path / "results", robot="panda")
    workspace = runner.profile.workspace
    assert runner.bags("sphere").as_posix() == "bags/panda/sphere"
    assert runner.situations("sphere_test") == situations.dataset("sphere_test", workspace)
    assert runner.candidates.robot == "panda" and runner.robot.profile.name == "panda"
    runner.evaluate(runner.situations("sphere_test")[:2], None, "teacher")
    assert asked == ["panda"]
    assert runner_module.Runner(tmp_path / "paper").bags("sphere").as_posix() == "bags/sphere"
