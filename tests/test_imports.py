"""Every package imports in a fresh interpreter without a display."""

import ast
import importlib.util
import os
import pathlib
import re
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


def console_scripts() -> dict:
    """{module: executable} of every console script in the packages' setup.py files."""
    found = {}
    for setup in (pathlib.Path(__file__).parents[1] / "ros_ws" / "src").glob("*/setup.py"):
        for executable, module in re.findall(r'"([\w-]+) = ([\w.]+):main"', setup.read_text()):
            found[module] = executable
    return found


def imported_modules(module: str) -> set:
    """Every module module's source imports, a `from package import name` as package.name too."""
    tree = ast.parse(pathlib.Path(importlib.util.find_spec(module).origin).read_text())
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(alias.name for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module:
            names.add(node.module)
            names.update(f"{node.module}.{alias.name}" for alias in node.names)
    return names


def test_command_line_tools_import_libraries_never_another_tool():
    """A tool's code lives in libraries that any tool may import; a node's module is a library
    of its node class."""
    scripts = console_scripts()
    tools = {module for module in scripts if not module.endswith("_node")}
    assert {"tric_control.evaluate_cli", "tric_learning.record_cli"} <= tools
    for tool in sorted(tools):
        others = imported_modules(tool) & (tools - {tool})
        assert not others, f"{scripts[tool]} ({tool}) imports the tool(s) {sorted(others)}"
