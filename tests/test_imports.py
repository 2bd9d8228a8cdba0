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
    """The in-process tools offer --viz (tric_sim.viz.view_options) but import foxglove-sdk only
    when asked."""
    code = (
        "import sys, tric_control.demo_cli, tric_control.evaluate_cli, tric_learning.record_cli; "
        "print(sorted(m for m in sys.modules if m.split('.')[0] in ('foxglove', 'websockets')))"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "[]"


def entry_points() -> dict:
    """{executable: (entry module, function)} of every console script in the packages' setup.py
    files."""
    found = {}
    for setup in (pathlib.Path(__file__).parents[1] / "ros_ws" / "src").glob("*/setup.py"):
        for executable, module, function in re.findall(
            r'"([\w-]+) = ([\w.]+):(\w+)"', setup.read_text()
        ):
            found[executable] = (module, function)
    return found


def started_module(entry: str, function: str) -> tuple:
    """(how the entry point starts its tool or node: "command_main" or "node_main", the module it
    imports then), read from the entry module's source."""
    source = pathlib.Path(importlib.util.find_spec(entry).origin).read_text()
    found = re.search(
        rf'def {function}\(\) -> int:\n    return (command_main|node_main)\("[\w-]+", "([\w.]+)"\)',
        source,
    )
    assert found, f"{entry}:{function} does not start its tool through command_main or node_main"
    return found.group(1), found.group(2)


def console_scripts() -> dict:
    """{module: executable} of every console script: the module of its tool or node."""
    return {started_module(*entry)[1]: executable for executable, entry in entry_points().items()}


def test_every_entry_point_handles_interrupts_before_its_imports():
    """Ctrl-C in the first half second of tric-eval or tric-train (its imports) gave a 40-line
    traceback: every console script now starts through command_main (tools) or node_main (nodes),
    whose module imports no more than signal, threading and importlib, before it imports the
    tool's."""
    kinds = {started_module(*entry)[0] for entry in entry_points().values()}
    assert kinds == {"command_main", "node_main"}
    code = (
        "import sys; before = set(sys.modules); import tric_sim.tools.interrupts; "
        "print(' '.join(sorted(set(sys.modules) - before)))"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0, proc.stderr
    standard = {"signal", "threading", "_weakrefset", "importlib", "importlib._bootstrap"}
    standard |= {"importlib._bootstrap_external"}
    ours = {"tric_sim", "tric_sim.tools", "tric_sim.tools.interrupts"}
    assert set(proc.stdout.split()) <= standard | ours


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


#: The libraries an answer to --help or to a bad argument must not wait for (issue 25: tric-eval's
#: --help took 6 s): each takes 0.3 to 3 s to import.
HEAVY_LIBRARIES = ("torch", "pybullet", "pinocchio", "rclpy", "matplotlib", "ray")

#: Each command-line tool: arguments it refuses, and a part of its refusal.
BAD_ARGUMENTS = {
    "tric_control.evaluate_cli": (["sphere_test", "--teacher", "--jobs", "0"], "must"),
    "tric_control.demo_cli": (["--jobs", "0"], "--jobs must be at least 1"),
    "tric_control.experiments.cli": (["--jobs", "0"], "--jobs must be in [1, 64]"),
    "tric_control.study.cli": (["--variant", "v=hand_lead=-0.1"], "hand_lead must be >= 0"),
    "tric_control.train_cli": (["some.mcap", "--alpha-g", "-1"], "must"),
    "tric_learning.record_cli": (["sphere_train", "--period", "0"], "must"),
    "tric_learning.analyze_cli": (["m.safetensors", "b.mcap", "--top", "0"], "--top must be"),
    "tric_sim.snapshot": (["sphere_grid_13", "--strip", "1"], "--strip takes 2 to 12 frames"),
    "tric_sim.robot_check": (["--samples", "0"], "--samples takes at least 1"),
}


def test_every_command_line_tool_is_checked_for_a_fast_answer():
    tools = {module for module in console_scripts() if not module.endswith("_node")}
    assert tools == set(BAD_ARGUMENTS)


@pytest.mark.parametrize("module", sorted(BAD_ARGUMENTS))
def test_help_and_argument_errors_answer_before_the_heavy_libraries(module):
    """--help exits 0 and a bad argument 2, each with its text, before torch, pybullet, pinocchio,
    rclpy or matplotlib is imported."""
    bad_arguments, refusal = BAD_ARGUMENTS[module]
    for arguments, status, text in ((["--help"], 0, "usage:"), (bad_arguments, 2, refusal)):
        code = (
            f"import sys, {module} as tool\n"
            "try:\n"
            f"    status = tool.main({arguments!r})\n"
            "except SystemExit as end:\n"
            "    status = end.code\n"
            f"print('HEAVY', sorted(set({HEAVY_LIBRARIES!r}) & set(sys.modules)), 'STATUS', status)"
        )
        proc = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, timeout=120
        )
        assert proc.returncode == 0, proc.stderr
        assert f"HEAVY [] STATUS {status}" in proc.stdout, (arguments, proc.stdout, proc.stderr)
        assert text in proc.stdout + proc.stderr, (arguments, proc.stdout, proc.stderr)


def project_modules() -> dict:
    """{module name: its source file} of every module of the three Python packages."""
    root = pathlib.Path(__file__).parents[1] / "ros_ws" / "src"
    modules = {}
    for package in ("tric_sim", "tric_learning", "tric_control"):
        base = root / package
        for path in (base / package).rglob("*.py"):
            parts = path.relative_to(base).with_suffix("").parts
            name = ".".join(parts[:-1] if parts[-1] == "__init__" else parts)
            modules[name] = path
    return modules


def import_graph() -> dict:
    """{module: the project's modules it imports anywhere in its source (inside functions and under
    `if TYPE_CHECKING:` too: either only hides a circle)}."""
    modules = project_modules()
    graph = {}
    for name, path in modules.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        imported = set()
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                imported.update(alias.name for alias in node.names)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parent = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                    base = f"{parent}.{base}" if base else parent
                imported.add(base)
                imported.update(f"{base}.{alias.name}" for alias in node.names)
        graph[name] = {m for m in imported if m in modules and m != name}
    return graph


def test_no_module_imports_itself_through_others():
    """No import circle between the project's modules, counting imports inside functions and those
    for annotations only (either only hides a circle)."""
    graph = import_graph()
    state, path, circles = {}, [], []

    def visit(module):
        state[module] = "open"
        path.append(module)
        for other in sorted(graph[module]):
            if state.get(other) == "open":
                circles.append(path[path.index(other) :] + [other])
            elif other not in state:
                visit(other)
        path.pop()
        state[module] = "done"

    for module in sorted(graph):
        if module not in state:
            visit(module)
    assert not circles, "import circles: " + "; ".join(" -> ".join(c) for c in circles)


def test_packages_import_only_downward():
    """tric_sim imports neither tric_learning nor tric_control; tric_learning not tric_control."""
    order = ("tric_sim", "tric_learning", "tric_control")
    upward = [
        f"{module} -> {other}"
        for module, others in import_graph().items()
        for other in others
        if order.index(other.split(".")[0]) > order.index(module.split(".")[0])
    ]
    assert not upward, upward
