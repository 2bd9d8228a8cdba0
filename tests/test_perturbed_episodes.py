"""Perturbed episodes through the real nodes: tric-eval --perturb records the perturbation in the
episode's bag, and the bag's situation replays to the same outcome."""

import json

from tric_control import evaluate_cli
from tric_learning import bags
from tric_learning.bags.layout import SITUATION_TOPIC
from tric_sim.ros import messages
from tric_sim.world import situations
from tric_sim.world.perturbation_trials import Trial
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation_files import save_situations


def test_a_recorded_perturbed_episode_replays_to_the_same_outcome(tmp_path):
    """The teacher plans its grasp from the situation, so a target that jumps 10 cm mid-approach
    spoils it; the bag holds the jump, and running the bag's situation again spoils it the same
    way."""
    chosen = situations.dataset("sphere_test")[3:4]
    save_situations(tmp_path / "one.yaml", chosen)
    first = tmp_path / "first.json"
    arguments = ["--teacher", "--situations-file", str(tmp_path / "one.yaml")]
    assert (
        evaluate_cli.main(
            [*arguments, "--perturb", "jump:0.1", "--record", str(tmp_path / "bags")]
            + ["--json", str(first)]
        )
        == 0
    )
    [bag] = sorted((tmp_path / "bags").glob("*.mcap"))
    [message] = list(bags.read_bag(bag, topics=[SITUATION_TOPIC]))
    recorded = messages.situation_from_msg(message.message)
    assert recorded == Trial("jump", 0.1).apply(chosen[0], RobotModel())
    save_situations(tmp_path / "replay.yaml", [recorded])
    second = tmp_path / "second.json"
    assert (
        evaluate_cli.main(
            ["--teacher", "--situations-file", str(tmp_path / "replay.yaml"), "--json", str(second)]
        )
        == 0
    )
    [before] = json.loads(first.read_text())["episodes"]
    [after] = json.loads(second.read_text())["episodes"]
    assert before["situation"] == after["situation"] == recorded.name
    assert not before["success"] and before["failure"], before  # the jump spoiled the grasp
    assert after["success"] == before["success"] and after["failure"] == before["failure"]
    assert abs(after["grasp_cost"] - before["grasp_cost"]) < 0.01


def test_tric_eval_refuses_an_impossible_perturbation_before_any_episode(tmp_path, capsys):
    box = tmp_path / "box.yaml"
    save_situations(box, situations.dataset("box_test")[:1])
    for arguments, reason in (
        (["sphere_test", "--perturb", "shove:0.2"], "is not KIND:SIZE[@SECONDS]"),
        (["sphere_test", "--perturb", "push:-1"], "SIZE must be >= 0"),
        (["--situations-file", str(box), "--perturb", "jump:0.05"], "has no grasp target to move"),
        (["sphere_test", "--perturb", "start:9"], "no start 9 rad from its own"),
    ):
        status = _exit_status(["--teacher", *arguments, "--json", str(tmp_path / "out.json")])
        assert status == 2 and reason in capsys.readouterr().err
    assert not (tmp_path / "out.json").exists()


def _exit_status(arguments) -> int:
    try:
        return evaluate_cli.main(arguments)
    except SystemExit as error:  # argparse's refusals
        return error.code
