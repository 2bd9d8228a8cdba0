"""bag_info (tric_learning.bags.info): a bag described from its summary."""

from bag_samples import CUSTOM_DATA

from tric_learning import bags


def test_bag_info_reads_the_summary(bag, messages):
    info = bags.bag_info(bag)
    assert info.complete and info.path == bag
    assert info.message_count == len(messages)
    assert (info.start_ns, info.end_ns) == (1_000, 13_000)
    assert info.custom_data == CUSTOM_DATA
    assert info.topics["/samples"] == bags.TopicInfo(
        "/samples", "tric_msgs/msg/FeatureSample", 3, False
    )
    assert info.topics["/situation"].latched and not info.topics["/joint_states"].latched
