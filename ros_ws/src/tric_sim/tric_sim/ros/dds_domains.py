"""The DDS domains the in-process tools run their graphs in (no rclpy: the tools check a
--domain-id before they import the nodes)."""

import os

#: The last DDS domain id (Fast DDS: its ports must stay below 65536).
MAX_DOMAIN_ID = 232


def private_domain_id() -> int:
    """A DDS domain for an in-process graph that no other graph should share: the simulator's
    topics (/joint_states, /situation, ...) must not mix with those of another simulator or robot
    on the same network. Chosen from the process id in 1..100 (0 is left to the user's own
    graph)."""
    return 1 + os.getpid() % 100
