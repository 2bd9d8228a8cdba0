"""tric-train: it checks its output before training, names the demonstrations it cannot sample,
and names what it includes with --include-failed and --tolerant."""

import pytest
from demo_bags import sphere, write_demo_bag

from tric_control import train_cli
from tric_learning.bags.loader import load_dataset
from tric_learning.model_file import ModelFile
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation import Obstacle, Situation

#: An obstacle block around the robot's lower arm: every configuration near home collides with it.
BLOCKING_OBSTACLE = Obstacle("box", (0.3, 0.3, 0.3), (0.0, 0.0, 0.4))


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture(scope="module")
def good_bag(robot, tmp_path_factory):
    return write_demo_bag(tmp_path_factory.mktemp("good") / "good.mcap", robot, sphere("good"))


def test_tric_train_names_a_demonstration_without_collision_free_samples(robot, tmp_path, capsys):
    """Every candidate fails on it alike, in its own worker process: the demonstration's fault is
    the one line, not the candidates'."""
    blocked = Situation(
        name="blocked",
        task="grasp",
        object_kind="sphere",
        object_dimensions=(0.04,),
        object_position=(0.6, 0.1, 0.3),
        obstacles=(BLOCKING_OBSTACLE,),
    )
    bag = write_demo_bag(tmp_path / "bags" / "blocked.mcap", robot, blocked)
    load_dataset([bag], robot)
    status = train_cli.main(
        [str(bag), "--out", str(tmp_path / "m.safetensors"), "--noisy-samples", "5", "--quiet"]
        + ["--candidates", "2", "--executor", "processes", "--jobs", "2"]
    )
    assert status == 2
    assert capsys.readouterr().err.startswith(
        f"tric-train: demo 'blocked' (bag {bag}): none of its noisy samples"
    )
    assert not (tmp_path / "m.safetensors").exists()


def test_tric_train_checks_its_output_before_training(robot, good_bag, tmp_path, capsys):
    (tmp_path / "folder.safetensors").mkdir()
    (tmp_path / "earlier.safetensors").write_bytes(b"an earlier model")
    for out, reason in (
        ("/proc/x.safetensors", "/proc refuses new files"),
        (str(tmp_path / "folder.safetensors"), "is a folder"),
        (str(tmp_path / "earlier.safetensors"), "exists; give --overwrite to replace it"),
        (str(tmp_path / ("m" * 250 + ".safetensors")), "bytes the file system takes"),
    ):
        assert train_cli.main([str(good_bag), "--out", out, "--quiet"]) == 2
        error = capsys.readouterr().err
        assert error.startswith(f"tric-train: the model path {out[:150]}") and reason in error
        assert error.count("\n") == 1
    assert (tmp_path / "earlier.safetensors").read_bytes() == b"an earlier model"


def test_tric_train_names_what_it_includes_with_include_failed_and_tolerant(
    robot, tmp_path, capsys
):
    bags = tmp_path / "bags"
    for name, outcome in (("ok_1", "success"), ("ok_2", "success"), ("failed", "failure")):
        write_demo_bag(bags / f"{name}.mcap", robot, sphere(name, 0.55 + 0.05 * len(name)), outcome)
    part = write_demo_bag(bags / "killed.mcap", robot, sphere("killed"), "unfinished")
    tiny = ["--hidden-units", "2", "--noisy-samples", "5", "--iterations", "3", "--quiet"]
    tiny += ["--candidates", "1", "--executor", "processes"]
    assert train_cli.main([str(bags), "--out", str(tmp_path / "a.safetensors")] + tiny) == 2
    assert "failed.mcap (failed: grasp cost 0.6)" in capsys.readouterr().err
    assert (
        train_cli.main(
            [str(bags), "--out", str(tmp_path / "b.safetensors"), "--include-failed", "--tolerant"]
            + tiny
        )
        == 0
    )
    error = capsys.readouterr().err
    assert f"tric-train: reading {part} up to its end or damage" in error
    assert f"tric-train: included {bags / 'failed.mcap'} (failed: grasp cost 0.6)" in error
    assert ModelFile.load(tmp_path / "b.safetensors").info["demos"] == [
        "failed",
        "killed",
        "ok_1",
        "ok_2",
    ]
    assert not (tmp_path / "a.safetensors").exists()


def test_tric_train_checks_the_model_s_room_before_training(
    robot, good_bag, tmp_path, monkeypatch, capsys
):
    """A disk with 20 kB free for a model of about 43 kB (its bound 104 kB, and 3 kB more for the
    selection's provenance: 8 candidates rolled out from 1 demonstration): refused once the bags
    are read, before the training (before: 21 s of training, then a traceback)."""
    import collections

    from tric_control.selection import candidates
    from tric_sim.tools import output_files

    def never(*_, **__):
        raise AssertionError("the training ran")

    monkeypatch.setattr(candidates, "train", never)
    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(output_files.shutil, "disk_usage", lambda _: usage(10**9, 10**9, 20_000))
    out = tmp_path / "m.safetensors"
    assert train_cli.main([str(good_bag), "--out", str(out), "--quiet"]) == 2
    assert capsys.readouterr().err == (
        f"tric-train: the model path {out} cannot be written: {tmp_path} has 20.0 kB free, "
        "107 kB are needed\n"
    )
    assert list(tmp_path.iterdir()) == []


def test_a_disk_that_fills_while_the_model_is_written_ends_with_one_line(
    robot, good_bag, tmp_path, monkeypatch, capsys
):
    """The write fails after the training (ENOSPC): one line naming the path and the cause, no
    traceback (before: SafetensorError from the Rust writer), no file left."""
    import errno
    import pathlib

    written = pathlib.Path.write_bytes

    def full(path, data):
        if path.name.startswith(".tric-"):
            raise OSError(errno.ENOSPC, "No space left on device")
        return written(path, data)

    monkeypatch.setattr(pathlib.Path, "write_bytes", full)
    out = tmp_path / "m.safetensors"
    tiny = ["--kind", "dpl_joint", "--iterations", "2", "--hidden-units", "4", "--quiet"]
    assert train_cli.main([str(good_bag), "--out", str(out), *tiny]) == 2
    assert capsys.readouterr().err == (
        f"tric-train: {out} could not be written (No space left on device)\n"
    )
    assert list(tmp_path.iterdir()) == []
