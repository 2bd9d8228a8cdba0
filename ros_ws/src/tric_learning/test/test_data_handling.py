"""Nothing used or dropped in silence: failed demonstrations, unfinished recordings, a demonstration
recorded twice, a bag recorded by other feature code and a demonstration without collision-free
noisy samples are named; model files of
another format version, with a definition off its fingerprint or with non-finite arrays are
refused, and a cached model is re-used only when made as asked; damaged bags and random model files
(fuzzed with hypothesis) give a clear error or a correct result, never a traceback."""

import dataclasses
import json
import math
import os
import pathlib
import subprocess
import sys
import tempfile

import numpy as np
import pytest
from demo_bags import sphere, write_demo_bag
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st
from safetensors import safe_open
from safetensors.numpy import save_file

from tric_learning import model_file
from tric_learning.bags import recorder as bag_recorder
from tric_learning.bags import writer as bag_writer
from tric_learning.bags.loader import load_dataset
from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.model_file import ModelFile, value_function, value_function_arrays
from tric_learning.training import samples
from tric_learning.training.dataset import Dataset
from tric_learning.training.value import TrainingConfig, train
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.tools.provenance import code_digest
from tric_sim.world import situations as S
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation import Obstacle, Situation
from tric_sim.world.situation_files import save_situations

#: An obstacle block around the robot's lower arm: every configuration near home collides with it.
BLOCKING_OBSTACLE = Obstacle("box", (0.3, 0.3, 0.3), (0.0, 0.0, 0.4))


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture(scope="module")
def good_bag(robot, tmp_path_factory):
    return write_demo_bag(tmp_path_factory.mktemp("good") / "good.mcap", robot, sphere("good"))


def test_failed_demonstrations_and_missing_outcomes_are_refused_by_name(robot, tmp_path):
    for name, outcome in (
        ("ok_1", "success"),
        ("ok_2", "success"),
        ("failed", "failure"),
        ("silent", None),
    ):
        write_demo_bag(tmp_path / f"{name}.mcap", robot, sphere(name), outcome)
    with pytest.raises(ValueError) as refusal:
        load_dataset([tmp_path], robot)
    assert str(refusal.value) == (
        f"2 of 4 bags are not successful demonstrations: {tmp_path / 'failed.mcap'} (failed: "
        f"grasp cost 0.6); {tmp_path / 'silent.mcap'} (no recorded outcome). Leave them out, or "
        "include them on purpose (tric-train --include-failed)"
    )
    notes = []
    dataset = load_dataset([tmp_path], robot, include_failed=True, notice=notes.append)
    assert [demo.name for demo in dataset.demos] == ["failed", "ok_1", "ok_2", "silent"]
    assert notes == [
        f"included {tmp_path / 'failed.mcap'} (failed: grasp cost 0.6), as include_failed asks",
        f"included {tmp_path / 'silent.mcap'} (no recorded outcome), as include_failed asks",
    ]


def test_unfinished_recordings_are_named_when_skipped_and_read_with_tolerant(robot, tmp_path):
    write_demo_bag(tmp_path / "ok_1.mcap", robot, sphere("ok_1"))
    part = write_demo_bag(tmp_path / "killed.mcap", robot, sphere("killed"), "unfinished")
    notes = []
    assert [d.name for d in load_dataset([tmp_path], robot, notice=notes.append).demos] == ["ok_1"]
    assert notes == [f"skipped {part}: an unfinished recording (tric-train --tolerant reads it)"]
    with pytest.raises(
        ValueError, match=f"bag {part} is truncated or corrupt .*tric-train --tolerant reads those"
    ):
        load_dataset([part], robot)
    notes.clear()
    dataset = load_dataset(
        [tmp_path], robot, tolerant=True, include_failed=True, notice=notes.append
    )
    assert [(d.name, d.length) for d in dataset.demos] == [("killed", 5), ("ok_1", 5)]
    assert notes == [
        f"reading {part} up to its end or damage: it is not a finished bag",
        f"included {part} (no recorded outcome), as include_failed asks",
    ]


def test_a_demonstration_recorded_twice_names_both_bags(robot, tmp_path):
    write_demo_bag(tmp_path / "sphere_grid_00.mcap", robot, sphere("sphere_grid_00"))
    write_demo_bag(tmp_path / "sphere_grid_00_1.mcap", robot, sphere("sphere_grid_00"))
    with pytest.raises(
        ValueError,
        match=f"bags {tmp_path / 'sphere_grid_00.mcap'} and "
        f"{tmp_path / 'sphere_grid_00_1.mcap'} both hold the demonstration "
        "'sphere_grid_00' \\(recorded twice into one folder\\?\\)",
    ):
        load_dataset([tmp_path], robot)


def test_a_demonstration_without_collision_free_samples_is_named_with_its_bag(
    robot, tmp_path, capsys
):
    blocked = Situation(
        name="blocked",
        task="grasp",
        object_kind="sphere",
        object_dimensions=(0.04,),
        object_position=(0.6, 0.1, 0.3),
        obstacles=(BLOCKING_OBSTACLE,),
    )
    bag = write_demo_bag(tmp_path / "bags" / "blocked.mcap", robot, blocked)
    dataset = load_dataset([bag], robot)
    with pytest.raises(
        ValueError, match=f"demo 'blocked' \\(bag {bag}\\): none of its noisy samples"
    ):
        samples.generate(dataset, robot, 5, 0.05, 0)


def test_a_folder_a_device_or_a_pipe_is_not_called_a_missing_model_file(tmp_path):
    """/dev/zero or a FIFO given as a model was said to "not exist"."""
    with pytest.raises(ValueError, match=f"model file {tmp_path} is a folder, not a file"):
        ModelFile.load(tmp_path)
    fifo = tmp_path / "fifo"
    os.mkfifo(fifo)
    for path in ("/dev/zero", fifo):
        with pytest.raises(ValueError, match=f"model file {path} is not a regular file"):
            ModelFile.load(path)
    with pytest.raises(ValueError, match=f"model file {tmp_path / 'none'} does not exist"):
        ModelFile.load(tmp_path / "none")


def _rewrite_metadata(path: pathlib.Path, change) -> None:
    """Write path again with its arrays and its "tric" metadata as change(metadata dict) leaves
    it."""
    with safe_open(str(path), framework="numpy") as handle:
        meta = json.loads(handle.metadata()["tric"])
        arrays = {name: handle.get_tensor(name) for name in handle.keys()}
    change(meta)
    save_file(arrays, str(path), metadata={"tric": json.dumps(meta)})


def test_model_files_of_another_version_or_a_changed_definition_are_refused(robot, tmp_path):
    path = _tiny_model_file(robot).save(tmp_path / "model.safetensors")
    assert ModelFile.load(path, FeatureDefinition.for_task("grasp", robot)).kind == "tric"
    _rewrite_metadata(path, lambda meta: meta.update(version=2))
    with pytest.raises(ValueError) as refused:
        ModelFile.load(path)
    assert str(refused.value) == f"{path} has model format version 2; this reads 1"

    path = _tiny_model_file(robot).save(tmp_path / "edited.safetensors")
    # the same pairs, reordered
    _rewrite_metadata(path, lambda meta: meta["definition"]["pairs"].reverse())
    with pytest.raises(ValueError) as refused:
        ModelFile.load(path)
    assert (
        str(refused.value)
        == f"{path}: its feature definition does not match its recorded fingerprint"
    )

    path = _tiny_model_file(robot).save(tmp_path / "box.safetensors")
    with pytest.raises(ValueError, match=f"model {path}.*another feature definition"):
        ModelFile.load(path, FeatureDefinition.for_task("open_box", robot))


@pytest.mark.parametrize(
    "name, bad",
    [("w1", math.nan), ("w2", math.inf), ("w3", -math.inf), ("low", -math.inf), ("high", math.inf)],
)
def test_model_files_with_non_finite_arrays_are_refused(robot, tmp_path, name, bad):
    model = _tiny_model_file(robot)
    model.arrays[name] = model.arrays[name].astype(float)
    model.arrays[name].flat[-1] = bad
    # the file itself is readable
    loaded = ModelFile.load(model.save(tmp_path / "model.safetensors"))
    with pytest.raises(ValueError) as refused:
        value_function(loaded)
    assert str(refused.value) == f"the model file's {name} has non-finite values"


def _rewrite_arrays(path: pathlib.Path, change) -> None:
    """Write path again with its metadata and its arrays as change(arrays dict) leaves them."""
    with safe_open(str(path), framework="numpy") as handle:
        metadata = handle.metadata()
        arrays = {name: handle.get_tensor(name) for name in handle.keys()}
    change(arrays)
    save_file(arrays, str(path), metadata=metadata)


def _flip_lowest_bit(arrays):
    arrays["w1"].view(np.uint8).flat[0] ^= 1


@pytest.mark.parametrize(
    "change",
    [
        _flip_lowest_bit,
        lambda arrays: arrays.update(w1=arrays["w1"].reshape(-1, 1)),
        lambda arrays: arrays.update(kept=arrays["kept"].astype(np.int32)),
        lambda arrays: arrays.update(extra=np.zeros(1)),
    ],
    ids=["flipped bit", "reshaped", "other dtype", "extra array"],
)
def test_model_files_whose_arrays_are_not_their_digests_are_refused(robot, tmp_path, change):
    path = _tiny_model_file(robot).save(tmp_path / "model.safetensors")
    _rewrite_arrays(path, change)
    with pytest.raises(ValueError) as refused:
        ModelFile.load(path)
    assert str(refused.value) == (
        f"{path}: its arrays do not match the digest recorded with them (the file was damaged or "
        "edited); train the model again"
    )


def test_model_metadata_nested_too_deeply_is_refused_clearly(tmp_path):
    path = tmp_path / "deep.safetensors"
    save_file({"x": np.zeros(1)}, str(path), metadata={"tric": "[" * 100_000})
    with pytest.raises(ValueError) as refused:
        ModelFile.load(path)
    assert str(refused.value) == (
        f"model file {path}: its 'tric' metadata is not valid JSON: nesting deeper than 32 levels"
    )


def test_model_files_without_a_digest_load_with_a_warning(robot, tmp_path, caplog):
    model = _tiny_model_file(robot)
    path = model.save(tmp_path / "old.safetensors")
    _rewrite_metadata(path, lambda meta: meta.pop("digest"))
    loaded = ModelFile.load(path)
    assert all(np.array_equal(loaded.arrays[k], v) for k, v in model.arrays.items())
    assert f"{path} was written before model files carried a digest" in caplog.text


# --- fuzzed inputs ------------------------------------------------------------------------------

FUZZ = settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


def _load(path, robot, tolerant):
    """load_dataset's Dataset or its ValueError; anything else fails the test."""
    try:
        dataset = load_dataset(
            [path], robot, tolerant=tolerant, include_failed=True, notice=lambda _: None
        )
    except ValueError as error:
        assert str(path) in str(error), str(error)
        return error
    assert dataset.check() is dataset
    return dataset


@FUZZ
@given(data=st.data())
def test_bags_cut_at_any_byte_are_refused_or_read_up_to_the_cut(robot, good_bag, data):
    original = good_bag.read_bytes()
    cut = data.draw(st.integers(0, len(original) - 1), label="cut")
    reference = load_dataset([good_bag], robot).demos[0]
    with tempfile.TemporaryDirectory() as folder:
        path = pathlib.Path(folder) / "cut.mcap"
        path.write_bytes(original[:cut])
        # never taken for a finished bag
        assert isinstance(_load(path, robot, tolerant=False), ValueError)
        loaded = _load(path, robot, tolerant=True)
    if isinstance(loaded, Dataset):
        event("read up to the cut")
        demo = loaded.demos[0]
        assert np.array_equal(demo.q, reference.q[: demo.length])  # a prefix of the demonstration
    else:
        event("refused")


@FUZZ
@given(data=st.data())
def test_bags_with_flipped_bytes_are_refused_or_read_correctly(robot, good_bag, data):
    damaged = bytearray(good_bag.read_bytes())
    for _ in range(data.draw(st.integers(1, 4), label="flips")):
        position = data.draw(st.integers(0, len(damaged) - 1), label="position")
        damaged[position] ^= data.draw(st.integers(1, 255), label="mask")
    reference = load_dataset([good_bag], robot).demos[0]
    with tempfile.TemporaryDirectory() as folder:
        path = pathlib.Path(folder) / "flipped.mcap"
        path.write_bytes(bytes(damaged))
        for tolerant in (False, True):
            loaded = _load(path, robot, tolerant)
            event(f"tolerant={tolerant}: {type(loaded).__name__}")
            if isinstance(loaded, Dataset):  # read: the recorded samples, or a prefix of them
                demo = loaded.demos[0]
                assert np.array_equal(demo.q, reference.q[: demo.length])
                assert np.array_equal(demo.y, reference.y[: demo.length])


def _tiny_model_file(robot) -> ModelFile:
    definition = FeatureDefinition.for_task("grasp", robot)
    kept = np.arange(4)
    model = ValueFunction(
        Scaling(kept, np.zeros(4), np.ones(4), definition.size),
        np.ones((2, 4)),
        np.ones(2),
        np.ones(4),
    )
    return ModelFile("tric", definition, value_function_arrays(model), {"delta": 0.1, "rho": 1.0})


def _open_model(path):
    """ModelFile.load and value_function on path: the value function or the ValueError."""
    try:
        return value_function(ModelFile.load(path))
    except ValueError as error:
        assert str(error)
        return error


JSON = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=6),
    lambda inner: (
        st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=6), inner, max_size=3)
    ),
    max_leaves=10,
)


@FUZZ
@given(data=st.data())
def test_random_model_files_are_refused_clearly(robot, data):
    with tempfile.TemporaryDirectory() as folder:
        path = pathlib.Path(folder) / "model.safetensors"
        kind = data.draw(st.sampled_from(["bytes", "metadata", "arrays", "flipped"]), label="kind")
        if kind == "bytes":
            path.write_bytes(data.draw(st.binary(max_size=300), label="bytes"))
        # a valid safetensors file with generated arrays and "tric" metadata
        elif kind == "metadata":
            meta = data.draw(
                st.fixed_dictionaries(
                    {},
                    optional={
                        "format": st.just("tric-model") | JSON,
                        "version": st.just(1) | JSON,
                        "kind": st.sampled_from(["tric", "dpl_joint", "x"]) | JSON,
                        "definition": JSON,
                        "fingerprint": JSON,
                        "info": JSON,
                    },
                ),
                label="meta",
            )
            arrays = {
                name: np.asarray(
                    data.draw(st.lists(st.floats(width=32), min_size=1, max_size=4), label=name),
                    dtype=np.float32,
                )
                for name in data.draw(
                    st.lists(
                        st.sampled_from(["w1", "w2", "w3", "kept", "low", "high"]), unique=True
                    ),
                    label="arrays",
                )
            }
            save_file(arrays or {"x": np.zeros(1)}, str(path), metadata={"tric": json.dumps(meta)})
        elif kind == "arrays":  # a TRIC model file of the right definition with generated arrays
            model = _tiny_model_file(robot)
            for name in model.arrays:
                shape = data.draw(
                    st.lists(st.integers(0, 5), min_size=0, max_size=2), label=f"{name} shape"
                )
                dtype = data.draw(
                    st.sampled_from([np.float64, np.float32, np.int64]), label=f"{name} dtype"
                )
                values = data.draw(
                    st.lists(
                        st.floats(allow_nan=True, allow_infinity=True, width=32)
                        | st.integers(-10, 300),
                        min_size=int(np.prod(shape)),
                        max_size=int(np.prod(shape)),
                    ),
                    label=name,
                )
                with np.errstate(invalid="ignore"):
                    model.arrays[name] = (
                        np.array(values, dtype=np.float64).astype(dtype).reshape(shape)
                    )
            model.save(path)
        else:
            _tiny_model_file(robot).save(path)
            damaged = bytearray(path.read_bytes())
            damaged[data.draw(st.integers(0, len(damaged) - 1), label="position")] ^= data.draw(
                st.integers(1, 255)
            )
            path.write_bytes(bytes(damaged))
        event(f"{kind}: {type(_open_model(path)).__name__}")


def test_the_tiny_model_file_of_the_fuzz_test_loads(robot, tmp_path):
    path = _tiny_model_file(robot).save(tmp_path / "tiny.safetensors")
    assert isinstance(_open_model(path), ValueFunction)


def test_the_sampling_pool_ends_in_a_process_with_rclpy_signal_handlers():
    """Every node executable calls rclpy.init(), whose SIGTERM handler a forked worker inherits.
    Here a worker dies, so the executor ends the other with SIGTERM while that one is still starting
    (its fork is slowed down, as on a loaded machine), before it has reset its handlers: the pending
    work fails and the process ends (with a multiprocessing.Pool, whose workers wait on their
    queue, the exit waited for ever)."""
    script = (
        "import os, time, rclpy\nfrom tric_learning.training import samples\nrclpy.init()\n"
        "forks = []\n"
        "os.register_at_fork(before=lambda: forks.append(1),\n"
        "                    after_in_child=lambda: time.sleep(3.0 if len(forks) == 2 else 0.0))\n"
        "pool = samples.worker_pool(2)\npool.submit(os._exit, 1)\n"
        "try:\n    pool.submit(int).result()\nexcept Exception as error:\n"
        "    print(type(error).__name__)\npool.shutdown()\nprint('ended')\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0 and done.stdout == "BrokenProcessPool\nended\n", done.stderr


class ShiftedFeatureMap(FeatureMap):
    """Another feature code: every feature 1 mm off."""

    def with_jacobian(self, q, object_poses):
        y, jacobian = super().with_jacobian(q, object_poses)
        return y + 1e-3, jacobian


def test_a_bag_of_other_feature_code_is_refused_by_name(robot, good_bag, tmp_path, monkeypatch):
    """The recorded y and dphi/dq must be today's FeatureMap on the bag's own q and object poses;
    the reference bags are (test_bag_reader's reference test loads them with the check)."""
    assert load_dataset([good_bag], robot).demos[0].length == 5
    monkeypatch.setattr(bag_recorder, "FeatureMap", ShiftedFeatureMap)
    shifted = write_demo_bag(tmp_path / "shifted.mcap", robot, sphere("shifted"))
    monkeypatch.undo()
    with pytest.raises(ValueError, match=r"shifted\.mcap: its recorded features differ from today"):
        load_dataset([shifted], robot)
    assert load_dataset([shifted]).demos[0].y[0][0] == pytest.approx(
        load_dataset([good_bag]).demos[0].y[0][0] + 1e-3
    )  # without a robot nothing is recomputed


def test_a_bag_of_a_foreign_definition_of_our_type_is_refused_by_name(robot, tmp_path, monkeypatch):
    """A bag whose samples are named tric_msgs/msg/FeatureSample but defined otherwise (its
    messages decode, without the fields we read) is refused before any sample is read."""
    real = bag_writer.message_definition
    monkeypatch.setattr(
        bag_writer,
        "message_definition",
        lambda name, text=None: real(
            name,
            "std_msgs/Header header\nuint32 step\n" if name.endswith("FeatureSample") else text,
        ),
    )
    foreign = write_demo_bag(tmp_path / "foreign.mcap", robot, sphere("foreign"))
    monkeypatch.undo()
    with pytest.raises(
        ValueError,
        match=r"bag .*foreign\.mcap: topic /tric/samples holds tric_msgs/msg/FeatureSample of "
        r"another definition than this build's \(its tric_msgs/FeatureSample has the fields "
        r"\['header', 'step'\], this build's \['header', 'step', 'fingerprint', ",
    ):
        load_dataset([foreign], robot)


def test_the_dataset_fingerprint_covers_the_object_poses(robot, good_bag):
    dataset = load_dataset([good_bag], robot)
    before = dataset.fingerprint
    position, orientation = dataset.demos[0].object_poses[2]["object"]
    dataset.demos[0].object_poses[2] = {"object": (np.add(position, 1e-6), orientation)}
    assert dataset.fingerprint != before


def test_a_cached_model_is_reused_only_when_made_as_asked(robot, good_bag, tmp_path):
    dataset = load_dataset([good_bag], robot)
    config = TrainingConfig(hidden_units=2, noisy_samples=4, max_iterations=3)
    path = tmp_path / "cached.safetensors"
    code = code_digest("tric_learning.training.value")
    assert not model_file.made_as(path, "tric", config.to_dict(), dataset.fingerprint, code)
    model_file.from_training(train(dataset, robot, config), dataset).save(path)
    assert model_file.made_as(path, "tric", config.to_dict(), dataset.fingerprint, code)
    other = dataclasses.replace(config, alpha_g=1.0).to_dict()
    assert not model_file.made_as(path, "tric", other, dataset.fingerprint, code)
    assert not model_file.made_as(path, "tric", config.to_dict(), "another", code)
    assert not model_file.made_as(path, "tric", config.to_dict(), dataset.fingerprint, "old")
    assert not model_file.made_as(path, "dpl_joint", config.to_dict(), dataset.fingerprint, code)
    path.write_bytes(b"not a model")
    assert not model_file.made_as(path, "tric", config.to_dict(), dataset.fingerprint, code)


def test_tric_record_refuses_a_folder_without_room_for_the_bags_before_any_work(
    tmp_path, monkeypatch, capsys
):
    """A stand-in full disk (shutil.disk_usage): tric-record answers with one line and exit 2
    before any node starts or any bag is begun; the room it asks for grows with --duration (before:
    1 MB a demonstration whatever its length, so --duration 1e9 recorded without bound)."""
    import collections

    from tric_learning import record_cli
    from tric_sim.tools import output_files

    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(output_files.shutil, "disk_usage", lambda _: usage(10**9, 10**9, 10**5))
    out = tmp_path / "bags"
    needed = {}
    for duration in ("0", "5", "60", "120"):
        assert record_cli.main(["sphere_train", "--out", str(out), "--duration", duration]) == 2
        error = capsys.readouterr().err
        prefix = f"tric-record: --out {out} cannot be written: {out} has 100 kB free, "
        assert error.startswith(prefix) and error.endswith(" MB are needed\n"), error
        needed[duration] = float(error[len(prefix) :].split()[0])
    assert needed["0"] == needed["5"] == 25.4  # 27 bags of 5 s at 0.125 s: 0.94 MB each
    assert needed["5"] < needed["60"] < needed["120"]
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "option, value, message",
    [
        ("--duration", "1e9", "--duration must be in [0, 120] simulated s (0: the default)"),
        ("--duration", "inf", "--duration must be in [0, 120] simulated s (0: the default)"),
        ("--duration", "nan", "--duration must be in [0, 120] simulated s (0: the default)"),
        ("--period", "inf", "--period must be in (0, 10] simulated s"),
    ],
)
def test_tric_record_bounds_its_durations_before_any_work(tmp_path, capsys, option, value, message):
    """--duration 1e9 recorded without bound, --duration inf failed inside the teacher."""
    from tric_learning import record_cli

    with pytest.raises(SystemExit) as ended:
        record_cli.main(["sphere_train", "--out", str(tmp_path / "bags"), option, value])
    assert ended.value.code == 2
    assert capsys.readouterr().err.endswith(f"tric-record: error: {message}\n")
    assert list(tmp_path.iterdir()) == []


def test_tric_record_refuses_names_that_map_to_one_bag_and_its_own_input(tmp_path, capsys):
    """Situations named "grasp a", "grasp_a" and "grasp:a" became one bag (--overwrite) or
    grasp_a, grasp_a_1, grasp_a_2; a situations file in the folder named as a bag was recorded
    over. Both are refused before the first demonstration, and nothing is written."""
    from tric_learning import record_cli

    base = S.dataset("sphere_train")
    folder = tmp_path / "bags"
    colliding = tmp_path / "colliding.yaml"
    names = ["grasp a", "grasp_a", "grasp:a"]
    save_situations(colliding, [dataclasses.replace(base[k], name=n) for k, n in enumerate(names)])
    arguments = ["--out", str(folder), "--overwrite", "--situations-file"]
    assert record_cli.main([*arguments, str(colliding)]) == 2
    assert capsys.readouterr().err == (
        f"tric-record: the bags of 'grasp a' and 'grasp_a' would be one file, "
        f"{folder}/grasp_a.mcap: rename one\n"
    )
    assert not folder.exists()
    own = folder / "x.mcap"
    save_situations(own, [dataclasses.replace(base[0], name="x")])
    assert record_cli.main([*arguments, str(own)]) == 2
    assert "is an input of this run" in capsys.readouterr().err
    assert sorted(p.name for p in folder.iterdir()) == ["x.mcap"]
    assert own.read_text().startswith("situations:")
