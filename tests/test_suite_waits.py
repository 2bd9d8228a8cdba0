"""The suite waits on events, never by sleeping: no test module calls time.sleep or asyncio.sleep,
but where the sleep stands in for a slow process (listed below, each with why). A script that a
test runs in a child process is a string to this check, so its sleeps (a hung writer, a slow fork)
are the child's own."""

import ast
import pathlib

ROOT = pathlib.Path(__file__).resolve().parent.parent
#: The sleeps that make something slow on purpose: (file, enclosing function): why.
SLOW_ON_PURPOSE = {
    ("tests/test_offline.py", "late_for_the_simulator"): (
        "the simulator takes each command 50 ms late, so that a judge that did not wait for it "
        "would run first"
    ),
    (
        "tests/test_every_tool_interrupted.py",
        "test_a_tool_ends_within_two_seconds_of_a_signal_at_a_random_moment",
    ): "the signal's moment, drawn at random over the tool's imports and work: the test's input",
}


def sleeps(path: pathlib.Path):
    """(enclosing function, line) of every time.sleep(...), asyncio.sleep(...) or sleep(...)
    called in path."""
    tree = ast.parse(path.read_text(), str(path))
    found = []

    def visit(node, function):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                visit(child, child.name)
                continue
            if isinstance(child, ast.Call):
                callee = child.func
                if getattr(callee, "attr", getattr(callee, "id", "")) == "sleep":
                    found.append((function, child.lineno))
            visit(child, function)

    visit(tree, "<module>")
    return found


def test_no_test_sleeps_to_wait_for_an_event():
    modules = sorted(ROOT.glob("tests/*.py")) + sorted(ROOT.glob("ros_ws/src/*/test/*.py"))
    assert len(modules) > 50
    waits = [
        f"{path.relative_to(ROOT)}:{line} (in {function})"
        for path in modules
        for function, line in sleeps(path)
        if (str(path.relative_to(ROOT)), function) not in SLOW_ON_PURPOSE
    ]
    assert waits == [], "sleeps that wait for an event: " + ", ".join(waits)


def test_the_check_finds_a_sleep(tmp_path):
    module = tmp_path / "test_example.py"
    module.write_text(
        "import time\n\ndef test_x():\n    while not done():\n        time.sleep(0.01)\n"
        "\nasync def other():\n    await asyncio.sleep(0.1)\n\nSCRIPT = 'time.sleep(60)'\n"
    )
    assert sleeps(module) == [("test_x", 5), ("other", 8)]
