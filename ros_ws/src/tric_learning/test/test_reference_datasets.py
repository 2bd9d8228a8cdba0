"""The reference datasets committed under bags/ (issue: features, recorder and datasets): each loads
with tric_learning's reader, and `rosbags`, an independent reader of rosbag2 bags, reads the same
samples from every bag."""

import pathlib

import numpy as np
import pytest
import yaml
from mcap.reader import make_reader
from rosbags.highlevel import AnyReader

from tric_learning.recording import SAMPLES_TOPIC, bag_paths, load_dataset
from tric_sim.robot_model import RobotModel

BAGS = pathlib.Path(__file__).resolve().parents[4] / "bags"


@pytest.mark.parametrize("folder, task, demos, samples", [
    ("sphere", "grasp", 27, 40), ("cylinder", "grasp", 10, 40), ("box", "open_box", 10, 64)])
def test_reference_dataset_loads_and_rosbags_reads_the_same_samples(folder, task, demos, samples, tmp_path):
    files = bag_paths([BAGS / folder])
    dataset = load_dataset(files, RobotModel())
    assert dataset.definition.task == task
    assert [demo.length for demo in dataset.demos] == [samples] * demos
    assert all(demo.metrics.get("success") for demo in dataset.demos)
    for bag, demo in zip(files, dataset.demos):
        # rosbags reads a rosbag2 folder: the bag and the metadata.yaml that is its "rosbag2" record
        (tmp_path / bag.name).symlink_to(bag)
        with open(bag, "rb") as file:  # the last record: the one written when the bag was closed
            metadata = [yaml.safe_load(m.metadata["serialized_metadata"])
                        for m in make_reader(file).iter_metadata() if m.name == "rosbag2"][-1]
        (tmp_path / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": metadata}))
        with AnyReader([tmp_path]) as reader:
            connections = [c for c in reader.connections if c.topic == SAMPLES_TOPIC]
            read = [reader.deserialize(raw, c.msgtype) for c, _, raw in reader.messages(connections=connections)]
        assert np.array_equal([message.q for message in read], demo.q), bag.name
        assert np.array_equal([message.y for message in read], demo.y), bag.name
        (tmp_path / bag.name).unlink()
