"""The entry points of tric_learning's command-line tools (`ros2 run tric_learning TOOL`): each
ends cleanly on SIGINT or SIGTERM from its first instant, its imports included
(tric_sim.tools.interrupts.command_main)."""

from tric_sim.tools.interrupts import command_main


def tric_record() -> int:
    return command_main("tric-record", "tric_learning.record_cli")


def tric_analyze() -> int:
    return command_main("tric-analyze", "tric_learning.analyze_cli")
