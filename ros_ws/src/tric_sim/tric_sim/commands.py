"""The entry points of tric_sim's command-line tools (`ros2 run tric_sim TOOL`): each ends cleanly
on SIGINT or SIGTERM from its first instant, its imports included
(tric_sim.tools.interrupts.command_main)."""

from tric_sim.tools.interrupts import command_main


def tric_snapshot() -> int:
    return command_main("tric-snapshot", "tric_sim.snapshot")


def tric_robot_check() -> int:
    return command_main("tric-robot-check", "tric_sim.robot_check")
