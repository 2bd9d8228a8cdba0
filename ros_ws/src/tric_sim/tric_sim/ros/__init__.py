"""The ROS plumbing every package uses: QoS profiles and the in-process graph, node parameters,
message conversions, waiting on topics from a thread of one's own, and the tools' DDS domains."""
