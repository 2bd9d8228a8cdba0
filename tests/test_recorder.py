"""The recorder through the real nodes: bags readable by this project and by rosbags, with the same
numbers; bad bags refused; a killed recorder leaves its finished bags intact; an aborted episode
leaves no bag; tric-record refuses bad arguments, situations files and output folders before
recording."""

import errno
import json
import math
import pathlib
import shutil
import signal
import subprocess
import sys

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState

from conftest import FolderChanges, publisher_matches, run_periods, wait_for
from tric_learning import bags, record_cli
from tric_learning.bags.layout import SAMPLES_TOPIC
from tric_learning.bags.loader import load_dataset
from tric_learning.demonstrations import demonstrate_all
from tric_learning.recorder_node import RecorderNode
from tric_msgs.msg import EpisodeEvent, ObjectPoses, TaskMetrics
from tric_sim.ros import messages
from tric_sim.viz import scene_view
from tric_sim.world import scene, situations
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation_files import save_situations


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    """Two sphere demonstrations and one box opening, recorded by tric-record's graph."""
    out = tmp_path_factory.mktemp("bags")
    chosen = situations.sphere_grid()[3:5] + situations.dataset("box_train")[:1]
    rows = demonstrate_all(chosen, out, 0.125, 0.0, progress=False)
    assert all(result.success and path for _, result, path in rows)
    return out, rows


def test_a_five_second_demonstration_is_forty_samples(recorded):
    out, rows = recorded
    dataset = load_dataset([out / "sphere_grid_03.mcap", out / "sphere_grid_04.mcap"], RobotModel())
    assert [demo.length for demo in dataset.demos] == [40, 40]
    demo = dataset.demos[0]
    # a sample at the first control period (10 ms) at or after each 125 ms of the episode
    offsets = demo.stamps_ns - demo.stamps_ns[0] - np.arange(40) * 125_000_000
    assert np.all((offsets >= 0) & (offsets < 10_000_000))
    # every demonstration starts where its situation puts the robot, not where the previous one
    # (and its lift test) left it
    for recorded_demo in dataset.demos:
        assert np.allclose(recorded_demo.q[0], RobotModel().home, atol=1e-3)
    assert demo.metrics["success"] and demo.metrics["lift_tested"]
    assert demo.situation == situations.sphere_grid()[3] and demo.source == "teacher"
    info = bags.bag_info(out / "sphere_grid_03.mcap")
    assert (
        info.complete
        and info.custom_data["tric.task"] == "grasp"
        and "tric.outcome" in info.custom_data
    )
    # the profile the bag was made with, by name and digest
    assert info.custom_data["tric.robot_profile"] == RobotModel().profile.identity
    assert all(d.robot_profile == RobotModel().profile.identity for d in dataset.demos)
    assert info.topics["/joint_states"].message_count >= 499  # every control period of the 5 s
    # nothing after the episode's END (the lift test that follows it moves the robot on)
    stamps = {
        topic: [m.stamp_ns for m in bags.read_bag(out / "sphere_grid_04.mcap", topics=[topic])]
        for topic in ("/episode", "/joint_states", "/object_poses", SAMPLES_TOPIC)
    }
    end_ns = stamps["/episode"][1]
    assert max(stamps["/joint_states"] + stamps["/object_poses"]) <= end_ns
    assert max(stamps[SAMPLES_TOPIC]) < end_ns


def test_bags_of_another_version_of_the_profile_load_with_a_notice(recorded, tmp_path):
    """The bags load on the robot of an edited profile (a pre-shape changed: the same URDF and
    landmarks), each named with the profile's two digests; on the profile they were made with,
    quietly."""
    out, _ = recorded
    paths = [out / "sphere_grid_03.mcap", out / "sphere_grid_04.mcap"]
    notices: list = []
    load_dataset(paths, RobotModel(), notice=notices.append)
    assert notices == []
    profile = RobotModel().profile
    data = yaml.safe_load(profile.path.read_text())
    data.update(urdf=str(profile.urdf_path), srdf=str(profile.srdf_path))
    data["preshapes"]["sphere"]["finger_1_distal_joint"] += 0.01
    (tmp_path / "edited.yaml").write_text(yaml.safe_dump(data))
    edited = RobotModel(tmp_path / "edited.yaml")
    dataset = load_dataset(paths, edited, notice=notices.append)
    assert len(dataset.demos) == 2 and len(notices) == 2
    for path, notice in zip(paths, notices):
        assert notice.startswith(f"{path} was made with another version of the robot profile")
        assert f"(digest {profile.digest[:12]}, now {edited.profile.digest[:12]})" in notice


def test_rosbags_reads_the_same_samples(recorded, tmp_path):
    out, _ = recorded
    bag = out / "sphere_grid_03.mcap"
    with open(bag, "rb") as file:
        metadata = [
            yaml.safe_load(m.metadata["serialized_metadata"])
            for m in make_reader(file).iter_metadata()
            if m.name == "rosbag2"
        ][-1]
    shutil.copy(bag, tmp_path / bag.name)
    (tmp_path / "metadata.yaml").write_text(
        yaml.safe_dump({"rosbag2_bagfile_information": metadata})
    )
    with AnyReader([tmp_path]) as reader:
        connections = [c for c in reader.connections if c.topic == SAMPLES_TOPIC]
        samples = [
            reader.deserialize(raw, c.msgtype)
            for c, _, raw in reader.messages(connections=connections)
        ]
    ours = [m.message for m in bags.read_bag(bag, topics=[SAMPLES_TOPIC])]
    assert len(samples) == len(ours) == 40
    for theirs, mine in zip(samples, ours):
        assert np.array_equal(theirs.q, mine.q) and np.array_equal(theirs.y, mine.y)
        assert np.array_equal(theirs.jacobian, mine.jacobian)
        assert (theirs.jacobian_rows, theirs.jacobian_cols) == (224, 14)


def test_bags_carry_the_scene_for_3d_replay(recorded):
    """/tf every 40 ms of the episode: with /tf_static, the links where the recorded joint states
    put them and the objects where /object_poses did; /scene_markers the situation's bodies and the
    robot."""
    out, _ = recorded
    path = out / "box_train_00.mcap"
    situation = situations.dataset("box_train")[0]
    info = bags.bag_info(path)
    assert {
        name: topic.type_name
        for name, topic in info.topics.items()
        if name in ("/tf", "/tf_static", "/robot_description", "/scene_markers")
    } == {
        "/tf": "tf2_msgs/msg/TFMessage",
        "/tf_static": "tf2_msgs/msg/TFMessage",
        "/robot_description": "std_msgs/msg/String",
        "/scene_markers": "visualization_msgs/msg/MarkerArray",
    }
    assert all(
        info.topics[name].latched for name in ("/tf_static", "/robot_description", "/scene_markers")
    )
    read = {}
    for message in bags.read_bag(
        path,
        topics=[
            "/tf",
            "/tf_static",
            "/robot_description",
            "/scene_markers",
            "/joint_states",
            "/object_poses",
        ],
    ):
        read.setdefault(message.topic, []).append(message)
    robot = RobotModel()
    assert read["/robot_description"][0].message.data == robot.urdf_path.read_text()
    tf_stamps = np.array([m.stamp_ns for m in read["/tf"]])
    assert np.all(np.diff(tf_stamps) >= 40_000_000) and np.all(np.diff(tf_stamps) < 50_000_000)
    assert len(tf_stamps) >= 8 / 0.05  # an 8 s box opening

    def transforms(msg):
        return scene_view.Transforms(
            tuple(t.header.frame_id for t in msg.transforms),
            tuple(t.child_frame_id for t in msg.transforms),
            np.array(
                [
                    [
                        t.transform.translation.x,
                        t.transform.translation.y,
                        t.transform.translation.z,
                    ]
                    for t in msg.transforms
                ]
            ),
            np.array(
                [
                    [
                        t.transform.rotation.x,
                        t.transform.rotation.y,
                        t.transform.rotation.z,
                        t.transform.rotation.w,
                    ]
                    for t in msg.transforms
                ]
            ),
        )

    static = transforms(read["/tf_static"][0].message)
    states = {m.stamp_ns: m.message for m in read["/joint_states"]}
    poses = {m.stamp_ns: m.message for m in read["/object_poses"]}
    for tf in read["/tf"][::50]:
        placements = scene_view.frame_placements(static, transforms(tf.message))
        state = states[tf.stamp_ns]
        robot.forward([state.position[list(state.name).index(j)] for j in robot.joint_names])
        for frame in ("palm_center", "finger_2_tip", "base_link"):
            assert np.allclose(
                placements[frame].homogeneous, robot.frame_placement(frame).homogeneous, atol=1e-9
            )
        lid = poses[tf.stamp_ns].poses[list(poses[tf.stamp_ns].names).index("lid")]
        assert np.allclose(
            placements["lid"].translation, [lid.position.x, lid.position.y, lid.position.z]
        )
    markers = read["/scene_markers"][0].message.markers
    # DELETEALL, then the robot's 21 primitives and the scene's bodies
    assert markers[0].action == 3
    by_frame = {m.header.frame_id: m for m in markers[1:] if m.ns == "scene"}
    assert sorted(by_frame) == ["lid", "object", "world"]
    side = situation.object_dimensions[0]
    lid = by_frame["lid"]
    assert (lid.scale.x, lid.scale.y, lid.scale.z) == pytest.approx(scene.lid_extents(side))
    assert lid.pose.position.x == pytest.approx(scene.lid_geometry_offset(side).translation[0])
    assert sum(m.ns == "robot" for m in markers) == 21 and all(m.frame_locked for m in markers[1:])


def test_bad_bags_are_refused_naming_the_file(recorded, tmp_path):
    out, _ = recorded
    sphere, box = out / "sphere_grid_03.mcap", out / "box_train_00.mcap"
    truncated = tmp_path / "truncated.mcap"
    truncated.write_bytes(sphere.read_bytes()[: sphere.stat().st_size // 2])
    with pytest.raises(ValueError, match="truncated.mcap"):
        load_dataset([truncated])
    with pytest.raises(ValueError, match="another feature definition.*task differs"):
        load_dataset([sphere, box])
    foreign = tmp_path / "notes.mcap"
    foreign.write_text("not a bag")
    with pytest.raises(ValueError, match="notes.mcap"):
        load_dataset([foreign])
    with pytest.raises(ValueError, match="does not exist"):
        load_dataset([tmp_path / "missing.mcap"])
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ValueError, match="holds no .mcap bags"):
        load_dataset([empty])


class EpisodePlayer(Node):
    """Plays a teacher's episode to the recorder: /episode events, /joint_states and /object_poses,
    stamped in simulated ns."""

    def __init__(self, context, situation):
        super().__init__("test_episode_player", context=context)
        self.situation, self.robot = situation, RobotModel()
        self.event_pub = self.create_publisher(EpisodeEvent, "/episode", 20)
        self.state_pub = self.create_publisher(JointState, "/joint_states", 1000)
        self.poses_pub = self.create_publisher(ObjectPoses, "/object_poses", 1000)

    def event(self, kind, episode_id, stamp_ns, metrics=None):
        msg = EpisodeEvent(event=kind, episode_id=episode_id, source="teacher")
        msg.header.stamp = messages.time_msg(stamp_ns)
        if kind == EpisodeEvent.START:
            msg.situation = messages.situation_to_msg(self.situation)
        if metrics is not None:
            msg.metrics = metrics
        self.event_pub.publish(msg)

    def states(self, first_ns, count):
        """count states of the arm moving a little, one every 10 ms from first_ns; the last
        stamp."""
        q = self.robot.home.copy()
        poses = {"object": (self.situation.object_position, self.situation.object_orientation)}
        for k in range(count):
            stamp = first_ns + k * 10_000_000
            q[:3] += 0.002
            self.poses_pub.publish(messages.object_poses_msg(poses, stamp))
            self.state_pub.publish(
                messages.joint_state_msg(self.robot.joint_names, q, np.zeros(len(q)), stamp)
            )
        return stamp


def recorder_and_player(ros_context, spin, tmp_path, *parameters):
    """A recorder node writing into tmp_path (with parameters besides) and an EpisodePlayer of a
    sphere grid situation, spun, the recorder subscribed to the player's topics."""
    recorder = RecorderNode(
        context=ros_context,
        parameter_overrides=[Parameter("output_dir", value=str(tmp_path)), *parameters],
    )
    player = EpisodePlayer(ros_context, situations.sphere_grid()[4])
    matches = [
        publisher_matches(player, publisher)
        for publisher in (player.event_pub, player.state_pub, player.poses_pub)
    ]
    spin(recorder, player)
    wait_for(lambda: all(matched() for matched in matches), what="the recorder's subscriptions")
    return recorder, player


def record_successful_episode(recorder, player, episode_id: str, start_ns: int):
    """START, 30 states, END and a successful OUTCOME of episode_id, waited for until the
    recorder has finished a bag."""
    player.event(EpisodeEvent.START, episode_id, start_ns)
    wait_for(
        lambda: recorder.busy, what=f"the bag of '{episode_id}' to open", changed=recorder.changed
    )
    last = player.states(start_ns, 30)
    player.event(EpisodeEvent.END, episode_id, last)
    player.event(
        EpisodeEvent.OUTCOME,
        episode_id,
        last,
        TaskMetrics(task="grasp", grasp_cost=0.1, success=True, lid_angle=math.nan),
    )
    wait_for(lambda: recorder.finished, what=f"the bag of '{episode_id}'", changed=recorder.changed)


def test_an_aborted_episode_leaves_no_bag_and_the_next_one_is_recorded(ros_context, spin, tmp_path):
    """START, 30 states, ABORT: the recorder discards the bag (no .mcap, no .part left) and names no
    failure; the next episode (START, states, END, OUTCOME) is recorded as usual."""
    recorder, player = recorder_and_player(ros_context, spin, tmp_path)
    player.event(EpisodeEvent.START, "aborted", 1_000_000_000)
    wait_for(
        lambda: recorder.busy, what="the aborted episode's bag to open", changed=recorder.changed
    )
    assert [p.name for p in tmp_path.iterdir()] == ["aborted.mcap.part"]
    last = player.states(1_000_000_000, 30)
    player.event(EpisodeEvent.ABORT, "aborted", last)
    wait_for(lambda: not recorder.busy, what="the abort", changed=recorder.changed)
    run_periods(player)
    assert list(tmp_path.iterdir()) == [] and recorder.finished == [] and recorder.failed == []

    record_successful_episode(recorder, player, "recorded", 2_000_000_000)
    assert recorder.finished == [tmp_path / "recorded.mcap"] and recorder.failed == []
    info = bags.bag_info(tmp_path / "recorded.mcap")
    assert info.complete and info.topics["/joint_states"].message_count == 30
    assert json.loads(info.custom_data["tric.outcome"])["success"] is True


def test_a_disk_that_fills_mid_episode_loses_that_episode_only(
    ros_context, spin, tmp_path, monkeypatch
):
    """A write that fails in the middle of an episode (ENOSPC from the bag writer, standing in
    for a full disk): its bag is discarded (no .part left to fill the disk), the episode named as
    not recorded with the cause, and the next episode recorded as usual."""
    from tric_learning.bags import recorder as bag_recorder

    written = {"states": 0, "failed": False}
    original = bag_recorder.BagRecorder.joint_state

    def filling(self, msg):  # the 11th state of the first episode fails to be written
        written["states"] += 1
        if written["states"] > 10 and not written["failed"]:
            written["failed"] = True
            raise OSError(errno.ENOSPC, "No space left on device")
        return original(self, msg)

    monkeypatch.setattr(bag_recorder.BagRecorder, "joint_state", filling)
    recorder, player = recorder_and_player(ros_context, spin, tmp_path)
    player.event(EpisodeEvent.START, "full", 1_000_000_000)
    wait_for(
        lambda: recorder.busy, what="the first episode's bag to open", changed=recorder.changed
    )
    player.states(1_000_000_000, 30)
    wait_for(lambda: recorder.failed, what="the failed write", changed=recorder.changed)
    ((episode, reason),) = recorder.failed
    assert episode == "full" and reason.startswith("its bag could not be written: ")
    assert "No space left on device" in reason and list(tmp_path.iterdir()) == []

    record_successful_episode(recorder, player, "recorded", 2_000_000_000)
    assert recorder.finished == [tmp_path / "recorded.mcap"]
    assert bags.bag_info(tmp_path / "recorded.mcap").complete


def test_bags_without_an_outcome_are_closed_complete_and_named_as_such(ros_context, spin, tmp_path):
    """A START before the last episode finished closes the last bag without an outcome; an ended
    episode whose outcome never comes is closed without one after outcome_timeout_s. Both bags are
    complete, carry no outcome, and training refuses them as such."""
    recorder, player = recorder_and_player(
        ros_context, spin, tmp_path, Parameter("outcome_timeout_s", value=0.01)
    )
    player.event(EpisodeEvent.START, "cut", 1_000_000_000)
    last = player.states(1_000_000_000, 30)
    player.event(EpisodeEvent.START, "silent", last + 10_000_000)
    wait_for(
        lambda: recorder.finished,
        what="the first bag closed by the second START",
        changed=recorder.changed,
    )
    last = player.states(last + 10_000_000, 30)
    player.event(EpisodeEvent.END, "silent", last)
    wait_for(
        lambda: len(recorder.finished) == 2,
        what="the second bag closed by the timeout",
        changed=recorder.changed,
    )
    assert recorder.finished == [tmp_path / "cut.mcap", tmp_path / "silent.mcap"]
    assert recorder.failed == [] and not recorder.busy
    for path in recorder.finished:
        info = bags.bag_info(path)
        assert info.complete and "tric.outcome" not in info.custom_data, path
        assert info.topics["/joint_states"].message_count == 30, path
    with pytest.raises(ValueError, match="2 of 2 bags are not successful") as refused:
        load_dataset([tmp_path])
    assert str(refused.value).count("(no recorded outcome)") == 2


def test_a_recorder_shut_down_mid_episode_leaves_that_bag_unfinished(ros_context, spin, tmp_path):
    """A recorder node destroyed (as on SIGINT) while an episode is open keeps its finished bags
    and leaves the open one as ".part" only, readable up to its last sample, and names it."""
    recorder, player = recorder_and_player(ros_context, spin, tmp_path)
    record_successful_episode(recorder, player, "done", 1_000_000_000)
    player.event(EpisodeEvent.START, "cut", 3_000_000_000)
    wait_for(lambda: recorder.busy, what="the second bag to open", changed=recorder.changed)
    last = player.states(3_000_000_000, 30)
    wait_for(
        lambda: _samples_in(tmp_path / "cut.mcap.part") >= 2,
        what="samples of the open episode",
        changed=recorder.changed,
    )
    recorder.destroy_node()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cut.mcap.part", "done.mcap"]
    assert bags.bag_info(tmp_path / "done.mcap").complete
    with pytest.raises(ValueError, match="an unfinished recording"):
        bags.bag_info(tmp_path / "cut.mcap.part")
    assert _samples_in(tmp_path / "cut.mcap.part") >= 2
    [(episode, reason)] = recorder.failed
    assert episode == "cut" and "left unfinished as" in reason and last > 0


def test_recorder_killed_mid_demonstration_keeps_finished_bags(tmp_path):
    changes = FolderChanges(tmp_path)
    process = subprocess.Popen(
        [sys.executable, "-m", "tric_learning.record_cli", "sphere_train", "--out", str(tmp_path)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
    )

    def finished_and_partial():
        finished = sorted(tmp_path.glob("*.mcap"))
        partial = sorted(tmp_path.glob("*.mcap.part"))
        return finished and partial and _samples_in(partial[0]) >= 5 and finished

    try:
        finished = changes.wait_for(
            finished_and_partial, process, what="a finished bag and a bag in progress at once"
        )
    finally:
        process.send_signal(signal.SIGKILL)
        process.wait()
        changes.close()
    dataset = load_dataset(finished, RobotModel())
    assert all(demo.length == 40 for demo in dataset.demos)
    interrupted = sorted(tmp_path.glob("*.mcap.part"))[0]
    with pytest.raises(ValueError):
        bags.bag_info(interrupted)  # an unfinished bag is not taken for a finished one
    samples = list(bags.read_bag(interrupted, topics=[SAMPLES_TOPIC], tolerant=True))
    assert len(samples) >= 5  # readable up to the last flushed sample


def _samples_in(path: pathlib.Path) -> int:
    try:
        return sum(1 for _ in bags.read_bag(path, topics=[SAMPLES_TOPIC], tolerant=True))
    except ValueError:
        return 0


def test_tric_record_checks_its_folder_before_recording(tmp_path, capsys):
    plain = tmp_path / "plain"
    plain.write_text("x")
    assert record_cli.main(["sphere_train", "--out", str(plain)]) == 2
    assert (
        capsys.readouterr().err
        == f"tric-record: --out {plain} cannot be used: {plain} is a file, not a folder\n"
    )
    assert record_cli.main(["sphere_train", "--out", str(tmp_path)]) == 2
    assert capsys.readouterr().err == (
        f"tric-record: --out {tmp_path} is not empty (plain); give --overwrite to "
        "record into it anyway\n"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["plain"]


@pytest.mark.parametrize(
    "arguments, message",
    [
        ([], "give either DATASET or --situations-file"),
        (
            ["sphere_train", "--situations-file", "{tmp}/one.yaml"],
            "give either DATASET or --situations-file",
        ),
        (["sphere_everywhere"], "argument dataset: invalid choice: 'sphere_everywhere'"),
        (["sphere_train", "--period", "0"], "--period must be in (0, 10] simulated s"),
        (
            ["sphere_train", "--duration", "-1"],
            "--duration must be in [0, 120] simulated s (0: the default)",
        ),
        (["sphere_train", "--domain-id", "233"], "--domain-id must be in [0, 232]"),
        (["sphere_train", "--period", "fast"], "argument --period: invalid float value: 'fast'"),
    ],
)
def test_tric_record_refuses_bad_arguments_with_status_2(tmp_path, capsys, arguments, message):
    out = tmp_path / "bags"
    with pytest.raises(SystemExit) as refused:
        record_cli.main([a.format(tmp=tmp_path) for a in arguments] + ["--out", str(out)])
    assert refused.value.code == 2
    error = capsys.readouterr().err
    assert error.startswith("usage: tric-record") and f"tric-record: error: {message}" in error, (
        error
    )
    assert not out.exists()


@pytest.mark.parametrize(
    "make, message",
    [
        (
            lambda folder: None,
            "cannot read situations file {folder}/none.yaml: No such file or directory",
        ),
        (
            lambda folder: (folder / "none.yaml").write_text("- name: [unclosed\n"),
            "{folder}/none.yaml is not valid YAML: expected ',' or ']', but got '<stream end>' at "
            "line 2, column 1",
        ),
        (
            lambda folder: (folder / "none.yaml").write_text("[]\n"),
            "{folder}/none.yaml holds no situations",
        ),
    ],
)
def test_tric_record_refuses_a_bad_situations_file_in_one_line(tmp_path, capsys, make, message):
    make(tmp_path)
    out = tmp_path / "bags"
    assert (
        record_cli.main(["--situations-file", str(tmp_path / "none.yaml"), "--out", str(out)]) == 2
    )
    error = capsys.readouterr().err
    assert error.startswith("tric-record: ") and message.format(folder=tmp_path) in error
    assert error.count("\n") == 1 and not out.exists()


def test_tric_record_refuses_a_bad_viz_port_before_recording(tmp_path, capsys):
    out = tmp_path / "bags"
    assert record_cli.main(["sphere_train", "--out", str(out), "--viz", "--viz-port", "70000"]) == 2
    assert capsys.readouterr().err.endswith(
        "tric-record: --viz-port must be in [1, 65535], got 70000\n"
    )
    assert not out.exists()


def test_overwrite_replaces_a_bag_of_the_same_name(tmp_path):
    situation_file = tmp_path / "one.yaml"
    save_situations(situation_file, situations.sphere_grid()[4:5])
    out = tmp_path / "bags"
    arguments = ["--situations-file", str(situation_file), "--out", str(out), "--duration", "1.0"]
    # a 1 s demonstration does not grasp (status 1), but it is recorded
    assert record_cli.main(arguments) == 1
    first = (out / "sphere_grid_04.mcap").stat().st_ino
    assert record_cli.main(arguments) == 2  # the folder is not empty any more
    assert record_cli.main(arguments + ["--overwrite"]) == 1
    # no sphere_grid_04_1.mcap copy
    assert sorted(p.name for p in out.iterdir()) == ["sphere_grid_04.mcap"]
    assert (out / "sphere_grid_04.mcap").stat().st_ino != first
    assert bags.bag_info(out / "sphere_grid_04.mcap").complete


def test_a_bag_the_recorder_cannot_write_is_reported_not_taken_for_a_success(tmp_path):
    # in the way of the bag, which overwrite may not replace
    (tmp_path / "sphere_grid_04.mcap").mkdir()
    rows = demonstrate_all(
        situations.sphere_grid()[4:5], tmp_path, 0.125, 1.0, progress=False, overwrite=True
    )
    ((_, result, path),) = rows
    assert path is None and not result.success
    assert result.message == (
        f"not recorded: bag {tmp_path / 'sphere_grid_04.mcap'} exists already; "
        "refusing to overwrite it"
    )
