"""read_bag (tric_learning.bags.reader): round trips checked by this reader, by `mcap` and by
`rosbags`; topic selection; damaged and foreign files; the reference datasets under bags/ read by
our reader and by `rosbags`."""

import math
import pathlib
import random
import shutil

import numpy as np
import pytest
import yaml
from bag_samples import CUSTOM_DATA, assert_same, feature_sample, rosbag2_metadata, write_bag
from mcap.reader import make_reader
from mcap.writer import Writer as McapWriter
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader
from sensor_msgs.msg import JointState

from tric_learning import bags
from tric_learning.bags.layout import SAMPLES_TOPIC
from tric_learning.bags.loader import bag_paths, load_dataset
from tric_msgs.msg import FeatureSample
from tric_sim.world.robot_model import RobotModel

REFERENCE_BAGS = pathlib.Path(__file__).resolve().parents[4] / "bags"


def test_read_bag_returns_what_was_written(bag, messages):
    read = list(bags.read_bag(bag))
    assert [(m.topic, m.stamp_ns) for m in read] == [(t, s) for t, _, s in messages]
    for (topic, expected, _), got in zip(messages, read):
        assert got.type_name == bags.ros_type_name(type(expected))
        assert_same(expected, got.message, topic)
    sample = read[2].message
    assert (
        math.isnan(sample.jacobian[3])
        and sample.y[1] == math.inf
        and math.copysign(1, sample.y[2]) < 0
    )
    assert read[7].message.data == bytes([0, 1, 2, 255, 0])


def _rosbag2_folder(bag, folder):
    """folder, made what rosbags reads: a rosbag2 directory with the bag file and the metadata.yaml
    that rosbag2 would write, which is the bag's own last "rosbag2" metadata record (written at
    close)."""
    folder.mkdir(parents=True, exist_ok=True)
    shutil.copy(bag, folder / bag.name)
    (folder / "metadata.yaml").write_text(
        yaml.safe_dump({"rosbag2_bagfile_information": rosbag2_metadata(bag)[-1]})
    )
    return folder


def test_rosbags_reads_the_same_messages(bag, messages, tmp_path):
    with AnyReader([_rosbag2_folder(bag, tmp_path)]) as reader:
        assert reader.message_count == len(messages)
        read = [(c.topic, t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages()]
    assert [(t, s) for t, s, _ in read] == [(t, s) for t, _, s in messages]
    for (topic, expected, _), (_, _, got) in zip(messages, read):
        assert_same(expected, got, topic)


def test_mcap_indexed_reader_reads_the_same_messages(bag, messages):
    with open(bag, "rb") as file:
        read = list(
            make_reader(file, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
                log_time_order=True
            )
        )
    assert [(c.topic, m.log_time) for _, c, m, _ in read] == [(t, s) for t, _, s in messages]
    for (topic, expected, _), (_, _, _, got) in zip(messages, read):
        assert_same(expected, got, topic)


def test_topic_selection_and_expected_types(bag):
    read = list(bags.read_bag(bag, topics=["/joint_states", "/nothing"]))
    assert [m.topic for m in read] == ["/joint_states", "/joint_states"]
    ok = bags.read_bag(
        bag,
        ["/samples"],
        expected_types={
            "/samples": FeatureSample,
            "/joint_states": "sensor_msgs/msg/JointState",
            "/missing": JointState,
        },
    )
    assert len(list(ok)) == 3
    with pytest.raises(
        ValueError,
        match=r"demo.mcap: topic /samples has type tric_msgs/msg/FeatureSample, "
        r"expected sensor_msgs/msg/JointState",
    ):
        bags.read_bag(bag, expected_types={"/samples": JointState})
    # tolerant reading checks when it meets the topic, before any of its messages
    read = bags.read_bag(bag, expected_types={"/samples": "sensor_msgs/JointState"}, tolerant=True)
    with pytest.raises(ValueError, match="expected sensor_msgs/JointState"):
        list(read)


def test_truncated_bag_is_refused_strictly_and_read_up_to_the_damage_tolerantly(messages, tmp_path):
    messages = messages + [
        ("/samples", feature_sample(step, n_joints=20, n_features=224), 20_000 + step)
        for step in range(2, 12)
    ]
    data = write_bag(tmp_path / "demo.mcap", messages).read_bytes()
    truncated = tmp_path / "truncated.mcap"
    truncated.write_bytes(data[: len(data) // 2])
    with pytest.raises(
        ValueError,
        match=r"truncated.mcap is truncated or corrupt at byte \d+ of \d+ .*"
        r"; \d+ messages before the damage are readable"
        r".*tric-train --tolerant reads those",
    ):
        bags.read_bag(truncated)
    with pytest.raises(ValueError, match="truncated or corrupt"):
        bags.bag_info(truncated)
    read = list(bags.read_bag(truncated, tolerant=True))
    assert 0 < len(read) < len(messages)
    for (topic, expected, stamp), got in zip(messages, read):
        assert (got.topic, got.stamp_ns) == (topic, stamp)
        assert_same(expected, got.message, topic)
    info = bags.bag_info(truncated, tolerant=True)
    assert not info.complete and info.message_count == len(read) and info.custom_data == CUSTOM_DATA


def test_every_truncation_yields_a_prefix_or_a_clear_error(tmp_path):
    """A cut every 29 bytes: strictly refused, tolerantly a prefix of the messages; every prefix
    length from none to all 5 is met along the way."""
    messages = [("/joint_states", JointState(name=["a"], position=[float(i)]), i) for i in range(5)]
    data = write_bag(tmp_path / "small.mcap", messages).read_bytes()
    cut_file = tmp_path / "cut.mcap"
    prefixes = set()
    for cut in range(0, len(data), 29):
        cut_file.write_bytes(data[:cut])
        with pytest.raises(ValueError):
            bags.read_bag(cut_file)
        if cut < 8:
            with pytest.raises(ValueError, match="not an MCAP bag"):
                bags.read_bag(cut_file, tolerant=True)
            continue
        read = [m.message.position[0] for m in bags.read_bag(cut_file, tolerant=True)]
        assert read == [float(i) for i in range(len(read))], cut
        assert bags.bag_info(cut_file, tolerant=True).message_count == len(read)
        prefixes.add(len(read))
    assert prefixes == set(range(6))


def test_corrupt_bytes_give_the_right_messages_or_a_clear_error(tmp_path):
    """100 single-bit flips, each read strictly and tolerantly: every read is refused with a
    ValueError or gives the right messages (strictly: all of them). The outcomes are counted, so
    that the test fails if the flips never reach a message (every read refused) or are never
    detected."""
    messages = [("/joint_states", JointState(name=["a"], position=[float(i)]), i) for i in range(5)]
    data = write_bag(tmp_path / "small.mcap", messages).read_bytes()
    corrupt_file = tmp_path / "corrupt.mcap"
    rng = random.Random(0)
    outcomes = {
        (tolerant, outcome): 0
        for tolerant in (False, True)
        for outcome in ("refused", "some", "all")
    }
    for position in sorted(rng.sample(range(len(data)), 100)):
        corrupt = bytearray(data)
        corrupt[position] ^= 1 << rng.randrange(8)
        corrupt_file.write_bytes(corrupt)
        for tolerant in (False, True):
            try:
                read = [
                    (m.stamp_ns, m.message.position[0])
                    for m in bags.read_bag(corrupt_file, tolerant=tolerant)
                ]
                bags.bag_info(corrupt_file, tolerant=tolerant)
            except ValueError:
                outcomes[tolerant, "refused"] += 1
                continue
            assert read == [(i, float(i)) for i in range(len(read))], position
            assert tolerant or len(read) == 5, position
            outcomes[tolerant, "all" if len(read) == 5 else "some"] += 1
    assert sum(outcomes.values()) == 200 and outcomes[False, "some"] == 0
    # flips found and flips harmless
    assert outcomes[False, "refused"] and outcomes[False, "all"], outcomes
    # tolerant: up to the damage
    assert outcomes[True, "some"] and outcomes[True, "all"], outcomes


def test_foreign_and_missing_files_are_refused_clearly(tmp_path):
    with pytest.raises(ValueError, match=r"bag .*nothing.mcap does not exist"):
        bags.read_bag(tmp_path / "nothing.mcap")
    with pytest.raises(ValueError, match="is not a file"):
        bags.bag_info(tmp_path)
    text = tmp_path / "notes.mcap"
    text.write_text("these are not the bytes you are looking for\n")
    with pytest.raises(
        ValueError, match="notes.mcap is not an MCAP bag: it does not start with the MCAP "
    ):
        bags.read_bag(text, tolerant=True)
    with pytest.raises(ValueError, match="not an MCAP bag"):
        bags.bag_info(text)
    (tmp_path / "empty.mcap").write_bytes(b"")
    with pytest.raises(ValueError, match="it is empty"):
        bags.read_bag(tmp_path / "empty.mcap")
    other = tmp_path / "other.mcap"
    with open(other, "wb") as file:
        writer = McapWriter(file)
        writer.start(profile="ros1")
        writer.finish()
    with pytest.raises(
        ValueError, match="other.mcap is an MCAP file but not a ROS 2 bag .profile 'ros1'"
    ):
        bags.read_bag(other)
    with pytest.raises(ValueError, match="not a ROS 2 bag"):
        bags.bag_info(other, tolerant=True)


@pytest.mark.parametrize(
    "folder, task, demos, samples",
    [("sphere", "grasp", 27, 40), ("cylinder", "grasp", 10, 40), ("box", "open_box", 10, 64)],
)
def test_reference_dataset_loads_and_rosbags_reads_the_same_samples(
    folder, task, demos, samples, tmp_path
):
    """The reference datasets committed under bags/ load with our reader, and rosbags reads the same
    samples from every bag."""
    files = bag_paths([REFERENCE_BAGS / folder])
    dataset = load_dataset(files, RobotModel())
    assert dataset.definition.task == task
    assert [demo.length for demo in dataset.demos] == [samples] * demos
    assert all(demo.metrics.get("success") for demo in dataset.demos)
    # recorded before situations had perturbations: they read as situations without any
    assert all(demo.situation.perturbations == () for demo in dataset.demos)
    for bag, demo in zip(files, dataset.demos):
        with AnyReader([_rosbag2_folder(bag, tmp_path / bag.stem)]) as reader:
            connections = [c for c in reader.connections if c.topic == SAMPLES_TOPIC]
            read = [
                reader.deserialize(raw, c.msgtype)
                for c, _, raw in reader.messages(connections=connections)
            ]
        assert np.array_equal([message.q for message in read], demo.q), bag.name
        assert np.array_equal([message.y for message in read], demo.y), bag.name


EXPECTED = {"/samples": FeatureSample}


@pytest.mark.parametrize(
    "definition, refusal",
    [
        ("# a comment of another version\n" + "\n", None),  # comments do not decode
        ("float64 x\n", r"its tric_msgs/FeatureSample has the fields \['x'\]"),
        ("float64 9x\n", "it does not parse: .*9x"),
    ],
)
def test_a_definition_that_is_not_ours_is_refused_by_name(tmp_path, definition, refusal):
    ours = bags.message_definition("tric_msgs/msg/FeatureSample").split("\n" + "=" * 80)[0]
    text = ours if refusal is None else ""
    path = tmp_path / "foreign.mcap"
    with bags.BagWriter(path) as writer:
        writer.add_topic_definition("/samples", "tric_msgs/msg/FeatureSample", definition + text)
    for tolerant in (False, True):  # checked from the summary, or on meeting the topic
        if refusal is None:
            assert list(bags.read_bag(path, expected_types=EXPECTED, tolerant=tolerant)) == []
            continue
        with pytest.raises(
            ValueError,
            match=r"bag .*foreign\.mcap: topic /samples holds tric_msgs/msg/FeatureSample of "
            rf"another definition than this build's \({refusal}",
        ):
            list(bags.read_bag(path, expected_types=EXPECTED, tolerant=tolerant))
