"""Another robot, end to end: the paper's robot under another profile's name (the same URDF) is
another robot. Its demonstrations are recorded through the nodes with the `robot` parameter, a
model is trained on them with tric-train --robot, run offline and through tric-eval --robot; the
bags and the model are refused on the default robot, naming both robots; tric-study --robot chooses
and measures a model of it on its own bags; a node refuses a robot it cannot load, and a node finds
a named situation in its robot's workspace."""

import contextlib
import io
import json
import re
import shutil

import pytest
import yaml
from rclpy.parameter import Parameter

from conftest import REFERENCE_BAGS
from tric_control import evaluate_cli, train_cli
from tric_control.evaluation.offline import OfflineEvaluator
from tric_control.study import cli as study_cli
from tric_learning.bags.loader import load_dataset
from tric_learning.demonstrations import demonstrate_all
from tric_learning.model_file import ModelFile
from tric_sim.simulator_node import SimulatorNode
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.robot_profile import PROFILE_DIR

#: How a model of other_arm is refused on the default robot: naming both.
OTHER_ROBOT = r"robot_model differs \('other_arm:[0-9a-f]+' instead of 'tric_arm_hand:"


@pytest.fixture(scope="module")
def other_arm(tmp_path_factory):
    """A profile file 'other_arm': the paper's robot under another name."""
    data = yaml.safe_load((PROFILE_DIR / "tric_arm_hand.yaml").read_text())
    data.update(
        name="other_arm",
        urdf=str(PROFILE_DIR / data["urdf"]),
        srdf=str(PROFILE_DIR / data["srdf"]),
    )
    path = tmp_path_factory.mktemp("robot") / "other_arm.yaml"
    path.write_text(yaml.safe_dump(data))
    return str(path)


@pytest.fixture(scope="module")
def recorded(other_arm, tmp_path_factory):
    """Two sphere demonstrations of other_arm, recorded through the nodes, and a model tric-train
    --robot made of them: (bags folder, model path)."""
    out = tmp_path_factory.mktemp("bags")
    chosen = situations.sphere_grid()[12:14]
    rows = demonstrate_all(chosen, out, 0.125, 0.0, progress=False, robot=other_arm)
    assert all(result.success and path for _, result, path in rows)
    model = tmp_path_factory.mktemp("model") / "other.safetensors"
    arguments = [str(out), "--out", str(model), "--robot", other_arm, "--quiet"]
    arguments += ["--hidden-units", "5", "--noisy-samples", "10", "--iterations", "20"]
    arguments += ["--candidates", "1", "--executor", "processes"]
    with contextlib.redirect_stdout(io.StringIO()):
        assert train_cli.main(arguments) == 0
    return out, model


def test_bags_and_models_name_their_robot_and_are_refused_on_another(other_arm, recorded):
    bags, model = recorded
    dataset = load_dataset([bags], RobotModel(other_arm))
    assert dataset.definition.robot_model.startswith("other_arm:")
    with pytest.raises(ValueError, match="another robot"):
        load_dataset([bags], RobotModel())
    situation = situations.sphere_grid()[12]
    evaluator = OfflineEvaluator("grasp", str(model), 40, robot=other_arm)
    try:
        record = evaluator.run(situation)
    finally:
        evaluator.close()
    assert record.steps > 0 and record.agent == "tric"
    with pytest.raises(ValueError, match=OTHER_ROBOT):
        OfflineEvaluator("grasp", str(model), 40)


def test_tric_eval_runs_a_model_on_its_robot_and_refuses_it_on_another(
    other_arm, recorded, tmp_path, capsys
):
    _, model = recorded
    situations_file = tmp_path / "one.yaml"
    situations_file.write_text(
        yaml.safe_dump({"situations": [situations.sphere_grid()[12].to_dict()]})
    )
    result = tmp_path / "r.json"
    common = ["--model", str(model), "--situations-file", str(situations_file)]
    common += ["--max-steps", "40", "--json", str(result)]
    assert evaluate_cli.main(common + ["--robot", other_arm]) in (0, 1)  # judged, good or not
    assert len(json.loads(result.read_text())["episodes"]) == 1
    assert evaluate_cli.main(common + ["--overwrite"]) == 2
    assert re.search(OTHER_ROBOT, capsys.readouterr().err)
    assert evaluate_cli.main(common + ["--robot", "no_robot", "--overwrite"]) == 2
    assert "no robot profile 'no_robot'" in capsys.readouterr().err


def test_tric_study_runs_on_the_robot_s_own_bags_and_keeps_one_robot_per_folder(
    other_arm, recorded, tmp_path, monkeypatch, capsys
):
    """tric-study --robot reads bags/ROBOT/<set> of the working directory: a task without them is
    refused before any work; a tiny study of other_arm chooses a model of other_arm and measures it
    on the obstacle set; the paper's robot's study is refused in that folder."""
    bags, _ = recorded
    shutil.copytree(bags, tmp_path / "bags" / "other_arm" / "sphere")
    (tmp_path / "bags" / "sphere").symlink_to(REFERENCE_BAGS / "sphere")
    monkeypatch.chdir(tmp_path)
    out = tmp_path / "study"
    common = ["--variant", "tiny=candidates=1,max_iterations=3,noisy_samples=3,grasp_steps=40"]
    common += ["--seeds", "0", "--jobs", "1", "--executor", "processes", "--out", str(out)]
    assert study_cli.main([*common, "--robot", other_arm, "--tasks", "box"]) == 2
    assert "no reference bags of the robot 'other_arm' in bags/other_arm/box" in (
        capsys.readouterr().err
    )
    assert study_cli.main([*common, "--robot", other_arm, "--tasks", "obstacle"]) == 0
    results = json.loads((out / "study.json").read_text())
    assert results["robot"] == "other_arm" and results["failed"] == {}
    row = results["rows"]["tiny/obstacle/0"]
    assert row["sets"]["obstacle_val"]["episodes"] == 10
    chosen = ModelFile.load(next((out / "models").glob("*.safetensors")))
    assert chosen.definition.robot_model.startswith("other_arm:")
    assert chosen.info["robot_profile"] == RobotModel(other_arm).profile.identity
    capsys.readouterr()
    assert study_cli.main([*common, "--tasks", "obstacle"]) == 2
    assert "holds a study of the robot 'other_arm', not 'tric_arm_hand'" in capsys.readouterr().err


def test_a_node_refuses_a_robot_it_cannot_load(ros_context):
    with pytest.raises(ValueError, match="parameter 'robot': no robot profile 'no_robot'"):
        SimulatorNode(
            context=ros_context, parameter_overrides=[Parameter("robot", value="no_robot")]
        )


def test_a_simulator_node_finds_a_named_situation_in_its_robot_s_workspace(ros_context):
    """The built-in data sets are the robot's own: the Panda's simulator starts in the Panda's
    sphere_test_00 (a 3 cm sphere in its grid), not the paper's."""
    node = SimulatorNode(
        context=ros_context,
        parameter_overrides=[
            Parameter("robot", value="panda"),
            Parameter("situation", value="sphere_test_00"),
        ],
    )
    try:
        panda = RobotModel("panda").profile.workspace
        assert node.world.situation == situations.dataset("sphere_test", panda)[0]
        assert node.world.situation != situations.dataset("sphere_test")[0]
        assert node.world.situation.object_dimensions == (panda.sphere_radius,)
    finally:
        node.destroy_node()
