"""Every node checks its parameters at startup: a value of the wrong type, not finite, or out of
range ends `ros2 run PKG NODE` with one line naming the parameter and exit status 2."""

import math
import pathlib
import subprocess

import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter

from tric_control import controller_node, trainer_node
from tric_learning import recorder_node
from tric_sim import simulator_node, teacher_node
from tric_sim.ros.parameters import AT_LEAST_ONE, POSITIVE, Range, declare


@pytest.mark.parametrize(
    "node, assignment, message",
    [
        (
            simulator_node,
            "control_rate_hz:=0.0",
            "simulator: parameter control_rate_hz must be in [1, 1000], got 0.0",
        ),
        (
            simulator_node,
            "physics_rate_hz:=.inf",
            "simulator: parameter physics_rate_hz must be finite, got inf",
        ),
        (
            simulator_node,
            "control_rate_hz:=.nan",
            "simulator: parameter control_rate_hz must be finite, got nan",
        ),
        (
            simulator_node,
            "solver_iterations:=-5",
            "simulator: parameter solver_iterations must be in [1, 1000], got -5",
        ),
        (
            simulator_node,
            "lockstep_timeout_s:=0.0",
            "simulator: parameter lockstep_timeout_s must be positive, got 0.0",
        ),
        (
            simulator_node,
            "mode:=fast",
            "simulator: parameter mode must be one of 'realtime', 'lockstep', got 'fast'",
        ),
        (
            teacher_node,
            "state_timeout_s:=-1",
            "teacher: parameter state_timeout_s must be positive, got -1",
        ),
        (
            recorder_node,
            "sample_period_s:=0.0",
            "recorder: parameter sample_period_s must be positive, got 0.0",
        ),
        (
            recorder_node,
            "outcome_timeout_s:=.inf",
            "recorder: parameter outcome_timeout_s must be finite, got inf",
        ),
        (
            recorder_node,
            "sources:=[1,2]",
            "recorder: parameter sources must be a list of strings, got [1, 2]",
        ),
        (
            recorder_node,
            "output_dir:=/proc/bags",
            "recorder: parameter output_dir /proc/bags cannot be written: /proc refuses new files",
        ),
        (
            recorder_node,
            "output_dir:=/proc/version",
            "recorder: parameter output_dir /proc/version cannot be used: /proc/version is a "
            "file, not a folder",
        ),
        (
            recorder_node,
            "overwrite:=maybe",
            "recorder: parameter overwrite must be true or false, got 'maybe'",
        ),
        (
            recorder_node,
            "status_topic:=3",
            "recorder: parameter status_topic must be a string, got 3",
        ),
        (
            trainer_node,
            "progress_period_s:=-0.5",
            "trainer: parameter progress_period_s must be at least 0, got -0.5",
        ),
        (
            trainer_node,
            "executor:=slurm",
            "trainer: parameter executor must be one of 'processes', 'ray', got 'slurm'",
        ),
        (
            trainer_node,
            "jobs:=65",
            "trainer: parameter jobs must be in [0, 64], got 65",
        ),
        (
            controller_node,
            "max_steps:=2.5",
            "controller: parameter max_steps must be an integer, got 2.5",
        ),
        (
            controller_node,
            "state_timeout_s:=.nan",
            "controller: parameter state_timeout_s must be finite, got nan",
        ),
    ],
)
def test_a_bad_parameter_ends_the_node_with_one_line_and_status_2(
    node, assignment, message, capsys
):
    assert node.main(["node", "--ros-args", "-p", assignment]) == 2
    error = capsys.readouterr().err
    assert error.startswith(message) and error.count("\n") == 1, error


def test_declare_converts_numbers_and_checks_types_and_ranges(ros_context):
    values = {"rate": 100, "count": 3.0, "flag": True, "names": ["a"], "ratio": 0.5}
    node = Node(
        "parameters_test",
        context=ros_context,
        parameter_overrides=[Parameter(k, value=v) for k, v in values.items()],
    )
    try:
        rate = declare(node, "rate", 10.0, "a rate", POSITIVE)
        assert rate == 100.0 and isinstance(rate, float)
        count = declare(node, "count", 1, "a count", AT_LEAST_ONE)
        assert count == 3 and isinstance(count, int)
        assert declare(node, "flag", False, "a flag") is True
        assert declare(node, "names", ["x"], "names") == ["a"]
        with pytest.raises(ValueError, match=r"parameter ratio must be in \(0, 0.25\], got 0.5"):
            declare(node, "ratio", 0.1, "a ratio", Range(0.0, 0.25, low_open=True))
        assert declare(node, "default", math.pi, "unset: the default") == math.pi
        description = node.describe_parameter("rate").description
        assert description == "a rate (positive)"
    finally:
        node.destroy_node()


#: The workspace's installed executables, as `ros2 run PKG EXE` starts them.
INSTALL = pathlib.Path(__file__).resolve().parent.parent / "ros_ws" / "install"
#: Seconds a node's --help may take on a loaded machine before the test gives up on it (it reads
#: the node module's docstring without importing it: well under a second).
HELP_S = 60.0


@pytest.mark.parametrize(
    "package, node, described",
    [
        ("tric_sim", "simulator", "PyBullet"),
        ("tric_sim", "teacher", "demonstrates situations"),
        ("tric_sim", "visualizer", "Foxglove"),
        ("tric_learning", "recorder", "one MCAP bag per episode"),
        ("tric_control", "trainer", "trains models from demonstration bags"),
        ("tric_control", "controller", "motion-rate control"),
    ],
)
def test_a_node_answers_help_without_starting(package, node, described):
    """`ros2 run tric_sim simulator --help` printed nothing of it and started the node; now it
    prints how to start it and its description, and exits 0; another argument before --ros-args
    is one line and exit 2."""
    executable = str(INSTALL / package / "lib" / package / node)
    shown = subprocess.run([executable, "--help"], capture_output=True, text=True, timeout=HELP_S)
    assert shown.returncode == 0, shown.stderr
    assert shown.stdout.startswith(f"usage: ros2 run {package} {node} [--ros-args -p NAME:=VALUE")
    assert described in shown.stdout and shown.stderr == ""
    wrong = subprocess.run(
        [executable, "--rate", "5"], capture_output=True, text=True, timeout=HELP_S
    )
    assert wrong.returncode == 2
    assert wrong.stderr == (
        f"{node}: unknown argument '--rate' (a node takes ROS arguments only: --ros-args -p "
        "NAME:=VALUE ...; --help describes it)\n"
    )
