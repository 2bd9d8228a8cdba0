"""BagWriter (tric_learning.bags.writer): the rosbag2 conventions of the file, the .part file,
bad input, and a writer killed with SIGKILL."""

import os
import signal
import subprocess
import sys

import geometry_msgs.msg
import pytest
import yaml
from bag_samples import CUSTOM_DATA, LATCHED, rosbag2_metadata
from mcap.reader import make_reader
from sensor_msgs.msg import JointState

from tric_learning import bags
from tric_msgs.msg import FeatureSample, Situation


def test_file_follows_rosbag2_mcap_conventions(bag, messages):
    with open(bag, "rb") as file:
        reader = make_reader(file)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
    assert {s.encoding for s in summary.schemas.values()} == {"ros2msg"}
    for schema in summary.schemas.values():
        assert schema.data.decode() == bags.message_definition(schema.name)
        assert schema.name.count("/msg/") == 1
    assert {c.compression for c in summary.chunk_indexes} == {"zstd"}
    assert len(summary.chunk_indexes) == len(messages)  # flush() after each message closes a chunk
    channels = {c.topic: c for c in summary.channels.values()}
    assert set(channels) == {t for t, _, _ in messages}
    for topic, channel in channels.items():
        assert channel.message_encoding == "cdr"
        (qos,) = yaml.safe_load(channel.metadata["offered_qos_profiles"])
        assert qos == {
            "history": "keep_last",
            "depth": 10,
            "reliability": "reliable",
            "durability": "transient_local" if topic in LATCHED else "volatile",
            "deadline": {"sec": 0, "nsec": 0},
            "lifespan": {"sec": 0, "nsec": 0},
            "liveliness": "automatic",
            "liveliness_lease_duration": {"sec": 0, "nsec": 0},
            "avoid_ros_namespace_conventions": False,
        }
        assert channel.metadata["topic_type_hash"].startswith("RIHS01_")


def test_rosbag2_metadata_record_is_version_9_with_counts(bag, messages):
    opening, final = rosbag2_metadata(bag)  # written at open and at close, as rosbag2 does
    assert opening["version"] == final["version"] == 9
    assert opening["message_count"] == 0 and opening["custom_data"] == CUSTOM_DATA
    assert final["storage_identifier"] == "mcap" and final["ros_distro"] == "jazzy"
    assert final["compression_format"] == "" and final["compression_mode"] == ""
    assert final["relative_file_paths"] == [bag.name] and final["custom_data"] == CUSTOM_DATA
    assert final["message_count"] == len(messages)
    stamps = [s for _, _, s in messages]
    assert final["starting_time"] == {"nanoseconds_since_epoch": min(stamps)}
    assert final["duration"] == {"nanoseconds": max(stamps) - min(stamps)}
    assert final["files"] == [
        {
            "path": bag.name,
            "starting_time": final["starting_time"],
            "duration": final["duration"],
            "message_count": len(messages),
        }
    ]
    counts = {t: sum(1 for topic, _, _ in messages if topic == t) for t, _, _ in messages}
    topics = {t["topic_metadata"]["name"]: t for t in final["topics_with_message_count"]}
    assert {name: t["message_count"] for name, t in topics.items()} == counts
    samples = topics["/samples"]["topic_metadata"]
    assert (
        samples["type"] == "tric_msgs/msg/FeatureSample"
        and samples["serialization_format"] == "cdr"
    )
    assert samples["type_description_hash"].startswith("RIHS01_")
    assert samples["offered_qos_profiles"][0]["durability"] == "volatile"
    (situation_qos,) = topics["/situation"]["topic_metadata"]["offered_qos_profiles"]
    assert situation_qos["durability"] == "transient_local"


def test_writer_refuses_a_message_class_generated_from_another_definition(tmp_path, monkeypatch):
    # A stale build: the generated class has other fields than the installed .msg declares (here a
    # JointState class posing as tric_msgs/FeatureSample), possibly only in a nested type.
    stale = type("FeatureSample", (JointState,), {"__module__": "tric_msgs.msg.feature_sample"})
    with bags.BagWriter(tmp_path / "demo.mcap") as writer:
        with pytest.raises(
            ValueError,
            match=r"has the fields \['header', 'name', .*declares \['header', "
            r"'step', .*rebuild tric_msgs",
        ):
            writer.add_topic("/samples", stale)
        monkeypatch.setattr(
            geometry_msgs.msg,
            "Pose",
            type("Pose", (JointState,), {"__module__": "geometry_msgs.msg.pose"}),
        )
        with pytest.raises(ValueError, match="Pose has the fields .* rebuild geometry_msgs"):
            writer.add_topic("/situation", Situation)


def test_writer_writes_a_part_file_and_renames_it_on_close(tmp_path):
    path = tmp_path / "sub" / "demo_1.mcap"
    writer = bags.BagWriter(path)
    writer.add_topic("/joint_states", JointState)
    writer.write("/joint_states", JointState(position=[1.0]), 5)
    writer.set_custom_data("outcome", "success")
    assert writer.part_path == tmp_path / "sub" / "demo_1.mcap.part"
    assert writer.part_path.exists() and not path.exists()
    assert writer.close() == path and writer.close() == path
    assert path.exists() and not writer.part_path.exists()
    assert bags.bag_info(path).custom_data == {"outcome": "success"}
    with pytest.raises(ValueError, match="is closed"):
        writer.write("/joint_states", JointState(), 6)
    with pytest.raises(FileExistsError, match="refusing to overwrite"):
        bags.BagWriter(path)


def test_writer_refuses_bad_input(tmp_path):
    with pytest.raises(ValueError, match="must end in '.mcap'"):
        bags.BagWriter(tmp_path / "demo.bag")
    with bags.BagWriter(tmp_path / "demo.mcap") as writer:
        writer.add_topic("/joint_states", JointState)
        with pytest.raises(ValueError, match="topic /samples was not added"):
            writer.write("/samples", JointState(), 1)
        with pytest.raises(TypeError, match="takes sensor_msgs/msg/JointState, got FeatureSample"):
            writer.write("/joint_states", FeatureSample(), 1)
        with pytest.raises(ValueError, match="stamp_ns"):
            writer.write("/joint_states", JointState(), -1)
        with pytest.raises(TypeError):
            writer.write("/joint_states", JointState(), 1.5)
        with pytest.raises(ValueError, match="was added already"):
            writer.add_topic("/joint_states", JointState)
        with pytest.raises(ValueError, match="starting with '/'"):
            writer.add_topic("joint_states", JointState)
        with pytest.raises(TypeError, match="not a ROS 2 message class"):
            writer.add_topic("/x", dict)
        with pytest.raises(TypeError, match="str to str"):
            writer.set_custom_data("n", 3)
    assert bags.bag_info(tmp_path / "demo.mcap").message_count == 0


def test_an_exception_in_the_with_block_discards_the_bag(tmp_path):
    path = tmp_path / "demo.mcap"
    with pytest.raises(RuntimeError):
        with bags.BagWriter(path) as writer:
            writer.add_topic("/joint_states", JointState)
            writer.write("/joint_states", JointState(), 1)
            raise RuntimeError("demo aborted")
    assert list(tmp_path.iterdir()) == []


def test_empty_bag(tmp_path):
    path = bags.BagWriter(tmp_path / "empty.mcap").close()
    assert list(bags.read_bag(path)) == []
    info = bags.bag_info(path)
    assert info.complete and info.topics == {}
    assert (info.message_count, info.start_ns, info.end_ns) == (0, 0, 0)


def test_a_writer_killed_with_sigkill_leaves_its_flushed_messages(tmp_path):
    child = (
        "import sys, time\nfrom sensor_msgs.msg import JointState\nfrom tric_learning.bags import "
        "BagWriter\nwriter = BagWriter(sys.argv[1], custom_data={'episode_id': "
        "'killed'})\nwriter.add_topic('/joint_states', JointState)\nfor i in range(5):\n    "
        "writer.write('/joint_states', JointState(name=['j'], position=[float(i)]), 1000 + i)\n   "
        " writer.flush()\nwriter.write('/joint_states', JointState(name=['j'], position=[5.0]), "
        "1005)  # not flushed\nprint('flushed', flush=True)\ntime.sleep(60)\n"
    )
    path = tmp_path / "killed.mcap"
    process = subprocess.Popen(
        [sys.executable, "-c", child, str(path)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
    )
    try:
        line = process.stdout.readline()
        if line.strip() != b"flushed":
            process.kill()
            pytest.fail(f"writer process failed: {process.communicate()[1].decode()}")
    finally:
        os.kill(process.pid, signal.SIGKILL)
        process.wait()
    part = tmp_path / "killed.mcap.part"
    assert part.exists() and not path.exists()
    with pytest.raises(ValueError, match="5 messages before the damage"):
        bags.read_bag(part)
    read = list(bags.read_bag(part, tolerant=True))
    assert [(m.stamp_ns, m.message.position[0]) for m in read] == [
        (1000 + i, float(i)) for i in range(5)
    ]
    info = bags.bag_info(part, tolerant=True)
    assert (
        not info.complete
        and info.message_count == 5
        and info.custom_data == {"episode_id": "killed"}
    )
