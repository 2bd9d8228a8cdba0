"""The docs agree with the code: every node's parameters are in its package's README, the
architecture page's layout is the tree's, and every decision page is in the decisions' index."""

import ast
import pathlib
import subprocess
import sys

import pytest

SRC = pathlib.Path(__file__).parents[1] / "ros_ws" / "src"


def declared_parameters(node_module: pathlib.Path) -> list:
    """The names of the parameters a node module declares (tric_sim.ros.parameters.declare)."""
    return [
        ast.literal_eval(call.args[1])
        for call in ast.walk(ast.parse(node_module.read_text()))
        if isinstance(call, ast.Call) and getattr(call.func, "id", "") == "declare"
    ]


@pytest.mark.parametrize("node", sorted(SRC.glob("*/*/*_node.py")), ids=lambda p: p.stem)
def test_every_parameter_of_a_node_is_in_its_package_readme(node):
    package = node.parents[1]
    readme = (package / "README.md").read_text()
    # a node may declare its parameters in a module of their own beside it (controller_parameters)
    own_module = node.with_name(node.name.replace("_node.py", "_parameters.py"))
    parameters = declared_parameters(node)
    if own_module.is_file():
        parameters += declared_parameters(own_module)
    assert parameters, f"{node.name} declares no parameter"
    missing = [name for name in parameters if f"`{name}`" not in readme]
    assert not missing, f"{package.name}/README.md lacks {missing} of {node.name}"


def test_the_architecture_page_lists_every_module_as_the_tree_has_it():
    script = pathlib.Path(__file__).parents[1] / "scripts" / "write_layout.py"
    result = subprocess.run(
        [sys.executable, str(script), "--check"], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 0, result.stderr


def test_every_decision_page_is_in_the_decisions_index():
    decisions = pathlib.Path(__file__).parents[1] / "docs" / "decisions"
    index = (decisions / "README.md").read_text()
    pages = sorted(p.name for p in decisions.glob("*.md") if p.name != "README.md")
    assert pages, "no decision page found"
    missing = [page for page in pages if f"]({page})" not in index]
    assert not missing, f"docs/decisions/README.md lacks {missing}"
