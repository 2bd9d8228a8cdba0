"""Fail before work, never after: output paths checked and written atomically; situations that
cannot physically be (the object or an obstacle in the robot or the table, the robot in the table
or in itself) refused with the pair named; generated (fuzzed) situation data refused clearly or
accepted."""

import dataclasses
import math

import pytest
import yaml
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.tools.output_files import (
    atomic_path,
    check_output_file,
    check_output_folder,
    write_text_atomic,
)
from tric_sim.world import situations as S
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.scene_check import check_scene
from tric_sim.world.situation import WORKSPACE_HIGH, WORKSPACE_LOW, Obstacle, Situation
from tric_sim.world.situation_files import load_situations


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def test_output_file_checks_name_the_problem_and_create_nothing(tmp_path):
    (tmp_path / "folder.json").mkdir()
    (tmp_path / "plain").write_text("x")
    refusals = {
        tmp_path / "folder.json": "is a folder",
        tmp_path / "plain" / "out.json": "plain is a file, not a folder",
        "/proc/x.safetensors": "/proc refuses new files",
    }
    for path, reason in refusals.items():
        with pytest.raises(ValueError, match=reason):
            check_output_file(path, what="--json file")
    with pytest.raises(ValueError, match=r"the model path .*m\.json must end in \.safetensors"):
        check_output_file(tmp_path / "m.json", (".safetensors",), "the model path")
    assert (
        check_output_file(tmp_path / "new" / "deeper" / "r.json")
        == tmp_path / "new" / "deeper" / "r.json"
    )
    assert sorted(p.name for p in tmp_path.rglob("*")) == ["folder.json", "plain"]


def test_output_folder_checks_refuse_files_unwritable_and_non_empty_folders(tmp_path):
    (tmp_path / "plain").write_text("x")
    with pytest.raises(ValueError, match="plain is a file, not a folder"):
        check_output_folder(tmp_path / "plain" / "bags")
    with pytest.raises(ValueError, match="refuses new files"):
        check_output_folder("/proc/bags")
    with pytest.raises(ValueError, match=r"--out .* is not empty \(plain\)"):
        check_output_folder(tmp_path, "--out", must_be_empty=True)
    assert check_output_folder(tmp_path, "--out") == tmp_path
    assert check_output_folder(tmp_path / "new", must_be_empty=True) == tmp_path / "new"
    assert not (tmp_path / "new").exists()


def test_atomic_writes_replace_whole_files_or_leave_the_old_one(tmp_path):
    path = tmp_path / "sub" / "result.json"
    write_text_atomic(path, "first\n")
    assert path.read_text() == "first\n"
    with pytest.raises(RuntimeError):
        with atomic_path(path) as temporary:
            temporary.write_text("half")
            raise RuntimeError("the writer failed")
    assert path.read_text() == "first\n"
    assert [p.name for p in path.parent.iterdir()] == ["result.json"]  # no temporary left


def _home_with(changes: dict) -> list:
    """The default robot's home configuration with some joints (index -> rad) changed."""
    q = RobotModel().home.copy()
    for index, value in changes.items():
        q[index] = value
    return q.tolist()


@pytest.mark.parametrize(
    "situation, reason",
    [
        (
            S.sphere("in_base", (0.0, 0.0, 0.05)),
            "the object \\(sphere\\) intersects the robot's base_link",
        ),
        (
            S.sphere("through_table", (0.6, 0.0, 0.1), radius=0.3),
            "the object \\(sphere\\) reaches 20.0 cm into the table",
        ),
        (
            Situation(
                name="sunk_box",
                task="open_box",
                object_kind="box",
                object_dimensions=(0.2,),
                object_position=(0.6, 0.0, 0.05),
            ),
            "the object \\(box\\) reaches 5.0 cm into the table",
        ),
        (
            Situation(
                name="plate_in_arm",
                task="grasp",
                object_kind="sphere",
                object_dimensions=(0.04,),
                object_position=(0.6, 0.0, 0.3),
                obstacles=(Obstacle("box", (0.3, 0.3, 0.3), (0.0, 0.0, 0.4)),),
            ),
            "obstacle 0 \\(box\\) intersects the robot's",
        ),
        (
            dataclasses.replace(
                S.sphere("arm_in_table", (0.6, 0.0, 0.3)),
                initial_joint_positions=tuple(_home_with({1: 1.9, 3: 0.5})),
            ),
            "the robot's arm_5_link reaches 10.4 cm into the table in its initial configuration",
        ),
        (
            dataclasses.replace(
                S.sphere("wrist_folded", (0.6, 0.0, 0.3)),
                initial_joint_positions=tuple(_home_with({5: 2.0})),
            ),
            "the robot's arm_5_link intersects its arm_7_link in its initial configuration",
        ),
    ],
)
def test_physically_impossible_situations_are_refused(robot, situation, reason, tmp_path):
    with pytest.raises(ValueError, match=f"situation '{situation.name}': {reason}"):
        check_scene(situation.validate(), robot)
    path = tmp_path / "situations.yaml"
    path.write_text(yaml.safe_dump({"situations": [situation.to_dict()]}))
    with pytest.raises(ValueError, match=reason):
        load_situations(path, robot)
    world = PhysicsWorld(robot)
    try:
        with pytest.raises(ValueError, match=reason):
            world.reset(situation)
    finally:
        world.close()


def test_every_built_in_situation_is_physically_possible(robot):
    for name in S.DATASETS:
        for situation in S.dataset(name):
            assert check_scene(situation, robot) is situation


# --- fuzzed situation data ----------------------------------------------------------------------

ANYTHING = st.recursive(
    st.none() | st.booleans() | st.integers() | st.floats() | st.text(max_size=8),
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4)
    ),
    max_leaves=8,
)
NUMBER = st.floats(allow_nan=True, allow_infinity=True) | st.integers(-(10**6), 10**6)
VECTOR = st.lists(NUMBER, min_size=0, max_size=5) | ANYTHING
FIELDS = {
    "name": st.text(max_size=12) | ANYTHING,
    "task": st.sampled_from(["grasp", "open_box", "juggle"]) | ANYTHING,
    "object_kind": st.sampled_from(["sphere", "cylinder", "box", "cone"]) | ANYTHING,
    "object_dimensions": VECTOR,
    "object_position": VECTOR,
    "object_orientation": VECTOR,
    "obstacles": st.lists(
        st.fixed_dictionaries(
            {},
            optional={
                "shape": st.sampled_from(["box", "sphere", "x"]) | ANYTHING,
                "dimensions": VECTOR,
                "position": VECTOR,
                "orientation": VECTOR,
            },
        ),
        max_size=2,
    )
    | ANYTHING,
    "initial_joint_positions": VECTOR,
    "seed": NUMBER | ANYTHING,
}
SITUATION_DATA = st.fixed_dictionaries({}, optional=dict(FIELDS, unknown_field=ANYTHING))


#: A valid sphere situation with one field replaced by a generated value.
NEAR_VALID = st.sampled_from(sorted(FIELDS)).flatmap(
    lambda key: FIELDS[key].map(
        lambda value: {**S.sphere("fuzzed", (0.6, 0.1, 0.3)).to_dict(), key: value}
    )
)

#: Spheres anywhere in the workspace, of any size: some inside the robot or the table.
SPHERES = st.tuples(
    *(st.floats(lo, hi) for lo, hi in zip(WORKSPACE_LOW, WORKSPACE_HIGH)), st.floats(0.001, 0.8)
).map(lambda v: S.sphere("fuzzed", v[:3], radius=v[3]).to_dict())


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=SITUATION_DATA | NEAR_VALID | SPHERES)
def test_generated_situation_data_is_refused_clearly_or_valid(robot, data):
    try:
        situation = Situation.from_dict(data)
    except ValueError as error:
        assert str(error)
        event("refused")
        return
    assert isinstance(situation.name, str) and situation.name
    assert all(math.isfinite(v) for v in situation.object_position + situation.object_dimensions)
    try:
        check_scene(situation, robot)
        event("valid, physically possible")
    except ValueError as error:
        assert f"situation '{situation.name}'" in str(error)
        event("valid, physically impossible")


def test_a_write_that_fails_names_the_path_and_keeps_the_file_before(tmp_path, monkeypatch):
    """A disk that fills during the write (os.replace standing in for the failing call): one
    OSError naming the path and the cause, the earlier file intact, no temporary file left."""
    import errno

    from tric_sim.tools import output_files

    target = tmp_path / "result.json"
    target.write_text("the earlier result")

    def full_disk(*_):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(output_files.os, "replace", full_disk)
    with pytest.raises(OSError) as failed:
        output_files.write_text_atomic(target, "a new result")
    assert failed.value.errno == errno.ENOSPC
    assert failed.value.strerror == f"{target} could not be written (No space left on device)"
    assert target.read_text() == "the earlier result"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["result.json"]


def test_output_files_refuse_too_little_free_space_and_keep_temporary_names_short(tmp_path):
    from tric_sim.tools import output_files

    with pytest.raises(ValueError, match=r"has [0-9.]+ [kMGT]B free, 1000000 TB are needed"):
        output_files.check_output_file(tmp_path / "x.json", expected_bytes=10**18)
    # the longest name whose siblings (its .partial, its lock) the file system takes
    longest = "n" * (255 - len(".json.partial")) + ".json"
    assert output_files.check_output_file(tmp_path / longest).name == longest
    output_files.write_text_atomic(tmp_path / longest, "fits")
    assert (tmp_path / longest).read_text() == "fits"
    for length in range(len(longest) + 1, 256):  # tric-eval --json with 250 to 255 characters
        with pytest.raises(ValueError, match=r"longer than the 255 bytes the file system takes"):
            output_files.check_output_file(tmp_path / ("n" * (length - 5) + ".json"))


def test_sizes_are_written_in_the_unit_that_reads_best():
    """Free room and needs read as people read them (before: "0.0 MB free, 0.0 MB are
    needed" for 20 kB and 43 kB)."""
    from tric_sim.tools.output_files import size_text

    assert [size_text(n) for n in (0, 999, 20_000, 43_008, 1_234_567, 150_000_000, 3 * 10**12)] == [
        "0 bytes",
        "999 bytes",
        "20.0 kB",
        "43.0 kB",
        "1.2 MB",
        "150 MB",
        "3.0 TB",
    ]


def test_output_folders_and_files_under_a_name_too_long_are_refused_before_work(tmp_path):
    """A folder name over the file system's limit (tric-record --out, a --json path inside it) is
    one ValueError, not an OSError after the work."""
    from tric_sim.tools import output_files

    long_folder = tmp_path / ("d" * 300)
    with pytest.raises(ValueError, match="is longer than the 255 bytes"):
        output_files.check_output_folder(long_folder, "--out")
    with pytest.raises(ValueError, match="is longer than the 255 bytes"):
        output_files.check_output_file(long_folder / "x.json", what="--json file")


def test_tric_snapshot_on_a_disk_that_fills_ends_with_one_line_and_keeps_the_earlier_picture(
    tmp_path, monkeypatch, capsys
):
    """The disk fills while the picture is written (os.replace standing in for the failing call):
    exit 2 with one line naming the path and the cause, no traceback, the earlier picture intact
    and no temporary file left."""
    import errno

    from tric_sim import snapshot
    from tric_sim.tools import output_files

    earlier = tmp_path / "sphere_grid_13.png"
    earlier.write_bytes(b"the earlier picture")

    def full_disk(*_):
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(output_files.os, "replace", full_disk)
    assert snapshot.main(["sphere_grid_13", "--size", "32", "24", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err == (
        f"tric-snapshot: {earlier} could not be written (No space left on device)\n"
    )
    assert earlier.read_bytes() == b"the earlier picture"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["sphere_grid_13.png"]


def test_an_output_folder_without_the_room_expected_is_refused(tmp_path, monkeypatch):
    """A stand-in full disk: check_output_folder refuses a folder with less free space than the
    expected size, and creates nothing."""
    import collections

    from tric_sim.tools import output_files

    usage = collections.namedtuple("usage", "total used free")
    monkeypatch.setattr(output_files.shutil, "disk_usage", lambda _: usage(10**9, 10**9, 0))
    with pytest.raises(ValueError, match="has 0 bytes free, 1.0 MB are needed"):
        output_files.check_output_folder(tmp_path / "new", "--out", expected_bytes=10**6)
    assert output_files.check_output_folder(tmp_path / "new", "--out") == tmp_path / "new"
    assert list(tmp_path.iterdir()) == []
