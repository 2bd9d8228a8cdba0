"""Every package imports in a fresh interpreter without a display."""

import os
import subprocess
import sys

import pytest


@pytest.mark.parametrize(
    "package",
    [
        "tric_msgs.msg",
        "tric_msgs.srv",
        "tric_msgs.action",
        "tric_sim",
        "tric_learning",
        "tric_control",
    ],
)
def test_imports_without_display(package):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    proc = subprocess.run(
        [sys.executable, "-c", f"import {package}"],
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stderr


def test_tools_load_nothing_of_foxglove_without_viz():
    """The in-process tools import the visualizer (for --viz) but not foxglove-sdk until asked."""
    code = (
        "import sys, tric_control.demo_cli, tric_control.evaluate_cli, tric_learning.record_cli; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('foxglove', 'websockets')))"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"
