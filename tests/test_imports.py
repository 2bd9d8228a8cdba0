"""Every package imports in a fresh interpreter without a display."""

import os
import subprocess
import sys

import pytest


@pytest.mark.parametrize("package", ["tric_msgs.msg", "tric_msgs.srv", "tric_msgs.action",
                                     "tric_sim", "tric_learning", "tric_control"])
def test_imports_without_display(package):
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    proc = subprocess.run([sys.executable, "-c", f"import {package}"], env=env,
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
