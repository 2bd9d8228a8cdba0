"""Message definitions as rosbag2 records them (tric_learning.bags.definitions), and the package's
independence of rclpy."""

import os
import subprocess
import sys

import pytest
from rosbags.typesys import get_types_from_msg

from tric_learning import bags
from tric_learning.bags import definitions


def test_the_module_does_not_import_rclpy():
    check = "import sys, tric_learning.bags; assert 'rclpy' not in sys.modules, sorted(sys.modules)"
    subprocess.run(
        [sys.executable, "-c", check],
        check=True,
        env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)},
    )


def test_message_definition_concatenates_dependencies_once_like_rosbag2():
    text = bags.message_definition("tric_msgs/msg/FeatureSample")
    separator = "\n" + "=" * 80 + "\n"
    parts = text.split(separator)
    assert (
        parts[0] == definitions._interface_file("tric_msgs/msg/FeatureSample", ".msg").read_text()
    )
    names = [p.split("\n", 1)[0] for p in parts[1:]]
    assert names == [
        "MSG: std_msgs/Header",
        "MSG: builtin_interfaces/Time",
        "MSG: tric_msgs/ObjectPoses",
        "MSG: geometry_msgs/Pose",
        "MSG: geometry_msgs/Point",
        "MSG: geometry_msgs/Quaternion",
    ]
    # Constants, default values, bounded arrays and trailing comments come through as installed.
    solid = bags.message_definition("shape_msgs/SolidPrimitive")
    assert "uint8 BOX=1" in solid and "float64[<=3] dimensions  # At no point" in solid
    assert "MSG: geometry_msgs/Point32" in solid
    assert "float64 w 1" in text
    # An independent parser reads every type out of it.
    types = get_types_from_msg(text, "tric_msgs/msg/FeatureSample")
    assert {
        "tric_msgs/msg/FeatureSample",
        "tric_msgs/msg/ObjectPoses",
        "std_msgs/msg/Header",
        "builtin_interfaces/msg/Time",
        "geometry_msgs/msg/Quaternion",
    } <= set(types)


def test_message_definition_of_an_unknown_type_is_a_clear_error():
    with pytest.raises(
        ValueError, match="no share/tric_msgs/msg/NoSuchType.msg under AMENT_PREFIX_PATH"
    ):
        bags.message_definition("tric_msgs/msg/NoSuchType")
    with pytest.raises(ValueError, match="not a message type name"):
        bags.message_definition("JointState")
