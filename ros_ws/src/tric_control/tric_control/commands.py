"""The entry points of tric_control's command-line tools (`ros2 run tric_control TOOL`): each ends
cleanly on SIGINT or SIGTERM from its first instant, its imports included
(tric_sim.tools.interrupts.command_main)."""

from tric_sim.tools.interrupts import command_main


def tric_train() -> int:
    return command_main("tric-train", "tric_control.train_cli")


def tric_eval() -> int:
    return command_main("tric-eval", "tric_control.evaluate_cli")


def tric_demo() -> int:
    return command_main("tric-demo", "tric_control.demo_cli")


def tric_experiments() -> int:
    return command_main("tric-experiments", "tric_control.experiments.cli")


def tric_study() -> int:
    return command_main("tric-study", "tric_control.study.cli")
