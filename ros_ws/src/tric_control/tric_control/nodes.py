"""The entry points of tric_control's nodes (`ros2 run tric_control NODE`): each ends cleanly on
SIGINT or SIGTERM from its first instant, its imports included
(tric_sim.tools.interrupts.node_main)."""

from tric_sim.tools.interrupts import node_main


def controller() -> int:
    return node_main("controller", "tric_control.controller_node")


def trainer() -> int:
    return node_main("trainer", "tric_control.trainer_node")
