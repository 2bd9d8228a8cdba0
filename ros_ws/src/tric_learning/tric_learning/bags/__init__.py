"""ROS 2 bags as single MCAP files, written and read without rclpy.

The files follow the conventions of rosbag2's MCAP storage plugin (ROS 2 Jazzy), so `ros2 bag info`,
`ros2 bag play` and Foxglove read them, and so does the independent reader `rosbags`:

- MCAP profile "ros2". One schema per message type: encoding "ros2msg", name "pkg/msg/Type", data
  the .msg text followed by the definitions it depends on, concatenated as rosbag2 does it (see
  `message_definition`). One channel per topic: message encoding "cdr", metadata
  "offered_qos_profiles" (rosbag2's YAML) and "topic_type_hash". Messages are CDR, little endian.
- Chunks are zstd-compressed. `BagWriter.flush` closes the current chunk, so a writer killed with
  SIGKILL loses only what it wrote after its last flush.
- A "rosbag2" metadata record (key "serialized_metadata": rosbag2's bag information, version 9) is
  written when the bag opens and again, final, when it closes, as rosbag2's writer does.
- The writer writes "<path>.part" and renames it to "<path>" on close(): a "*.mcap" file is always a
  finished bag. `read_bag(..., tolerant=True)` reads a ".part" left by a killed writer up to its
  last complete chunk.

Times are integer nanoseconds. Writing takes rclpy-generated message objects (e.g.
sensor_msgs.msg.JointState(...)); reading gives mcap_ros2's decoded objects, with the message's
field names as attributes: numbers and arrays of numbers as Python numbers and lists, uint8[]/byte[]
as bytes, nested messages as objects of the same kind (mcap_ros2 reads char as int8, so char values
above 127 come back negative). wstring fields are not supported.
"""

from tric_learning.bags.cdr import serialize_cdr
from tric_learning.bags.definitions import message_definition, ros_type_name
from tric_learning.bags.info import BagInfo, TopicInfo, bag_info
from tric_learning.bags.reader import BagMessage, read_bag
from tric_learning.bags.writer import (
    BAG_SUFFIX,
    DEFAULT_CHUNK_SIZE,
    PART_SUFFIX,
    ROS_DISTRO,
    ROSBAG2_METADATA_VERSION,
    BagWriter,
)

__all__ = [
    "BAG_SUFFIX",
    "DEFAULT_CHUNK_SIZE",
    "PART_SUFFIX",
    "ROS_DISTRO",
    "ROSBAG2_METADATA_VERSION",
    "BagInfo",
    "BagMessage",
    "BagWriter",
    "TopicInfo",
    "bag_info",
    "message_definition",
    "read_bag",
    "ros_type_name",
    "serialize_cdr",
]
