"""tric-demo, the main job, on small configurations: the built-in data sets it uses (the 27
sphere-grid demonstrations, the 15 test spheres) are cut down to a few situations, so that each run
takes seconds of episodes; everything else is the tool's own path. Recording, training, the
teacher's and TRIC's episodes through the nodes (--jobs 2: two worker graphs), the Table 1
comparison, demo.json and the figures, --check's exit code following the design's targets, and
refused arguments. The run on the reference bags takes the session's training of them (the training
tric-demo --reuse does; the other run goes through the tool's own training)."""

import json
import pathlib

import pytest

from conftest import REFERENCE_BAGS
from tric_control import demo, demo_cli
from tric_control.selection.candidates import rolled_out
from tric_control.selection.choice import choose
from tric_control.selection.select_model import Selection
from tric_control.selection.settings import SelectionConfig
from tric_learning.bags.loader import bag_paths, load_dataset
from tric_learning.training.dataset import Dataset
from tric_learning.training.value import TrainingConfig
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

BAGS = REFERENCE_BAGS / "sphere"
PNG = b"\x89PNG\r\n\x1a\n"


def cut_down(monkeypatch, train=(), test=()):
    """Make tric-demo's sphere_train and sphere_test data sets these situations."""
    chosen = {"sphere_train": list(train), "sphere_test": list(test)}
    monkeypatch.setattr(demo, "dataset", lambda name, workspace: chosen[name])


@pytest.mark.slow
def test_tric_demo_on_the_reference_bags(tmp_path, monkeypatch, capsys, reference_sphere_training):
    """--reuse bags/sphere --check --jobs 2 on two unseen spheres, TRIC trained with the defaults:
    every TRIC grasp is good, lifted and free of collisions (docs/design.md section 5, Table 1) and
    no joint went 0.01 rad past a limit (section 6); the verdicts printed and --check's exit code
    follow the numbers in demo.json. (Table 1's other target, TRIC's mean within 0.03 of the
    teacher's, is met by some trainings of these bags and missed by others: the training is
    repeatable on one machine, but another CPU rounds otherwise and gets another model; measured
    gaps on these two spheres from 0.028 to 0.033 on 2026-12-01, the last on the CI machine; see
    docs/fidelity.md's shortfalls.)"""
    tests = situations.dataset("sphere_test")[3:5]
    cut_down(monkeypatch, test=tests)
    asked = []

    def trained(bags, model, config, jobs, robot):
        """The session's reference training as the one candidate of a selection, rolled out from
        two of the demonstrations' starts (the tool's own selection is tested below)."""
        asked.append((pathlib.Path(bags), config, jobs, robot))
        demos = load_dataset(bag_paths([bags]), RobotModel())
        demos = Dataset(demos.definition, demos.demos[12:14])
        content = reference_sphere_training.path.read_bytes()
        record = {"losses": reference_sphere_training.result.losses}
        made = rolled_out(demos, content, 0, record)
        choice = choose([made], demos, config, SelectionConfig(candidates=1))
        choice.model.save(model)
        return Selection(choice, demos, [made], made.rollout_s, model)

    monkeypatch.setattr(demo, "train", trained)
    out = tmp_path / "results"
    status = demo_cli.main(["--reuse", str(BAGS), "--out", str(out), "--check", "--jobs", "2"])
    assert asked == [(BAGS, TrainingConfig(), 2, "tric_arm_hand")]
    report = json.loads((out / "demo.json").read_text())
    assert report["episodes"] == 4 and report["bags"] == str(BAGS)
    for agent in ("teacher", "tric"):
        records = report[agent]["episodes"]
        assert [r["situation"] for r in records] == [s.name for s in tests]
        for record in records:
            assert (
                record["grasp_cost"] < 0.25 and record["lift_passed"] and not record["collided"]
            ), record
            assert record["max_joint_overshoot"] <= 0.01
    assert report["tric_lift_passed"] == 2 and report["tric"]["summary"]["good_grasps"] == 2
    within = report["tric_cost_mean"] <= report["teacher_cost_mean"] + demo.MARGIN_TO_TEACHER
    printed = capsys.readouterr().out
    assert "[1/4] reusing the demonstrations in" in printed
    assert (
        f"TRIC mean within {demo.MARGIN_TO_TEACHER} of the teacher: "
        f"{'met' if within else 'NOT met'}; every TRIC grasp below 0.25: met"
    ) in printed
    assert status == (0 if within else 1)
    for name in ("demo.png", "demo_grasp.png"):
        assert (out / name).read_bytes()[:8] == PNG
    assert sorted(p.name for p in (out / "demo" / "snapshots").iterdir()) == [
        f"{s.name}.png" for s in tests
    ]


@pytest.mark.slow
def test_tric_demo_records_its_demonstrations_and_check_fails_when_tric_misses(
    tmp_path, monkeypatch, capsys
):
    """Without --reuse: two sphere-grid demonstrations recorded through the nodes, the default
    selection's candidates trained for one L-BFGS iteration each (models that cannot grasp) and
    rolled out from the two starts, one test sphere: the targets are reported as not met and
    --check makes the exit code 1; the results are written all the same, with every candidate."""
    cut_down(
        monkeypatch,
        train=situations.sphere_grid()[12:14],
        test=situations.dataset("sphere_test")[:1],
    )
    out = tmp_path / "results"
    assert demo_cli.main(["--out", str(out), "--iterations", "1", "--jobs", "1", "--check"]) == 1
    printed = capsys.readouterr().out
    assert "[1/4] recording" in printed and "every TRIC grasp below 0.25: NOT met" in printed
    assert sorted(p.name for p in (out / "demo" / "bags").iterdir()) == [
        "sphere_grid_12.mcap",
        "sphere_grid_13.mcap",
    ]
    report = json.loads((out / "demo.json").read_text())
    assert report["episodes"] == 2 and report["tric"]["summary"]["good_grasps"] == 0
    candidates = report["training"]["candidates"]
    assert sorted(c["seed"] for c in candidates) == list(range(SelectionConfig().candidates))
    assert [c["seed"] for c in candidates if c["chosen"]] == report["training"]["chosen"]
    assert report["tric"]["episodes"][0]["grasp_cost"] >= 0.25
    assert (out / "demo.png").read_bytes()[:8] == PNG
    stages = report["stages_s"]  # where the main job's time went (benchmarks/bench_main_job.py)
    walls = [
        "recording",
        "candidates_and_choice",
        "teacher_evaluation",
        "tric_evaluation",
        "table_and_figures",
    ]
    assert all(stages[name] > 0.0 for name in walls) and stages["recording"] > 1.0
    assert 0.0 < report["total_s"] - sum(stages[name] for name in walls) < 0.1 * report["total_s"]
    assert stages["candidates_training_summed"] == pytest.approx(
        sum(c["train_s"] for c in candidates)
    )


@pytest.mark.slow
def test_tric_demo_on_the_panda(tmp_path, monkeypatch, capsys):
    """--robot panda (make demo ROBOT=panda): two of the Panda's sphere-grid demonstrations
    recorded through the nodes, its candidates trained for one L-BFGS iteration each, one of its
    test spheres; the bags are the Panda's (refused on the paper's robot), demo.json names it, and
    the table has no paper row (the paper's numbers are its robot's)."""
    panda = RobotModel("panda")
    workspace = panda.profile.workspace
    cut_down(
        monkeypatch,
        train=situations.sphere_grid(workspace)[12:14],
        test=situations.dataset("sphere_test", workspace)[:1],
    )
    out = tmp_path / "results"
    arguments = ["--robot", "panda", "--out", str(out), "--iterations", "1", "--jobs", "1"]
    assert demo_cli.main(arguments) == 0
    printed = capsys.readouterr().out
    assert "mean (ours)" in printed and "mean (paper)" not in printed
    report = json.loads((out / "demo.json").read_text())
    assert report["robot"] == "panda" and report["episodes"] == 2
    assert report["teacher"]["episodes"][0]["grasp_cost"] < 0.1  # the Panda's teacher grasps
    bags = out / "demo" / "bags"
    assert load_dataset(bag_paths([bags]), panda).definition.robot_model.startswith("panda:")
    with pytest.raises(ValueError, match="another robot"):
        load_dataset(bag_paths([bags]), RobotModel())


def test_tric_demo_finds_the_robot_s_reference_bags():
    """--reuse without a folder takes the robot's reference sphere bags."""
    from tric_sim.tools.robot_option import reference_bags
    from tric_sim.world.robot_profile import load_profile

    assert reference_bags(load_profile(), "sphere") == pathlib.Path("bags/sphere")
    assert reference_bags(load_profile("panda"), "sphere") == pathlib.Path("bags/panda/sphere")
    assert (REFERENCE_BAGS / "panda" / "sphere" / "sphere_grid_00.mcap").is_file()


def test_tric_demo_refuses_bad_arguments(tmp_path, capsys):
    with pytest.raises(SystemExit) as refused:
        demo_cli.main(["--jobs", "0", "--out", str(tmp_path / "results")])
    assert (
        refused.value.code == 2
        and "tric-demo: error: --jobs must be at least 1" in capsys.readouterr().err
    )
    plain = tmp_path / "plain"
    plain.write_text("x")
    assert demo_cli.main(["--out", str(plain)]) == 2
    assert (
        capsys.readouterr().err
        == f"tric-demo: --out folder {plain} cannot be used: {plain} is a file, not a folder\n"
    )
    assert (
        demo_cli.main(["--reuse", str(tmp_path / "none"), "--out", str(tmp_path / "results")]) == 2
    )
    assert capsys.readouterr().err.endswith(f"tric-demo: {tmp_path / 'none'} does not exist\n")
    assert demo_cli.main(["--robot", "no_robot", "--out", str(tmp_path / "results")]) == 2
    assert "tric-demo: no robot profile 'no_robot'" in capsys.readouterr().err
    assert not list(tmp_path.rglob("*.json")) and not list(tmp_path.rglob("*.png"))
