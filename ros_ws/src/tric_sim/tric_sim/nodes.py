"""The entry points of tric_sim's nodes (`ros2 run tric_sim NODE`): each ends cleanly on
SIGINT or SIGTERM from its first instant, its imports included
(tric_sim.tools.interrupts.node_main)."""

from tric_sim.tools.interrupts import node_main


def simulator() -> int:
    return node_main("simulator", "tric_sim.simulator_node")


def teacher() -> int:
    return node_main("teacher", "tric_sim.teacher_node")


def visualizer() -> int:
    return node_main("visualizer", "tric_sim.visualizer_node")
