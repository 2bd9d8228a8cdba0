"""Fixtures of the bag tests: the sample messages and a bag of them."""

import pytest
from bag_samples import sample_messages, write_bag


@pytest.fixture(scope="module")
def messages():
    return sample_messages()


@pytest.fixture(scope="module")
def bag(tmp_path_factory, messages):
    return write_bag(tmp_path_factory.mktemp("bag") / "demo.mcap", messages)
