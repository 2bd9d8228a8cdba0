"""The code's shape: no module of the three Python packages over MAX_LINES lines (a longer one is
split by concern, as CONTRIBUTING.md says)."""

import pathlib

SRC = pathlib.Path(__file__).parents[1] / "ros_ws" / "src"
MAX_LINES = 400


def test_no_module_is_over_the_line_limit():
    modules = [
        path
        for package in ("tric_sim", "tric_learning", "tric_control")
        for path in (SRC / package / package).rglob("*.py")
    ]
    assert len(modules) > 100, "the packages' modules were not found"
    long = {
        str(path.relative_to(SRC)): lines
        for path in modules
        if (lines := len(path.read_text().splitlines())) > MAX_LINES
    }
    assert not long, f"modules over {MAX_LINES} lines: {long}"
