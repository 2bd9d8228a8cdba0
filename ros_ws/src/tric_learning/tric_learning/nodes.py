"""The entry points of tric_learning's nodes (`ros2 run tric_learning NODE`): each ends cleanly on
SIGINT or SIGTERM from its first instant, its imports included
(tric_sim.tools.interrupts.node_main)."""

from tric_sim.tools.interrupts import node_main


def recorder() -> int:
    return node_main("recorder", "tric_learning.recorder_node")
