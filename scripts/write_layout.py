"""Writes the layout section of docs/architecture.md from the tree: each package, its folders and
modules with the first sentence of each docstring, between the section's markers. With --check it
writes nothing and exits 1 if the section differs from the tree (tests/test_docs.py runs it).

    python scripts/write_layout.py [--check]
"""

import ast
import pathlib
import re
import sys

ROOT = pathlib.Path(__file__).resolve().parents[1]
PAGE = ROOT / "docs" / "architecture.md"
BEGIN, END = "<!-- layout: begin -->", "<!-- layout: end -->"
PACKAGES = ("tric_sim", "tric_learning", "tric_control")


def first_sentence(path: pathlib.Path) -> str:
    """The first sentence of a module's docstring (within its first paragraph), on one line."""
    paragraph = (ast.get_docstring(ast.parse(path.read_text())) or "").split("\n\n")[0]
    text = " ".join(paragraph.split())
    match = re.match(r"(.+?\.)(\s+[A-Z(`]|\s*$)", text)
    return (match.group(1) if match else text).rstrip(".")


def layout() -> str:
    """The layout section's text: one line per module, grouped by package and folder."""
    lines = []
    for package in PACKAGES:
        base = ROOT / "ros_ws" / "src" / package
        lines += [f"### `{package}`", ""]
        for path in sorted((base / package).rglob("*.py"), key=lambda p: (p.parent, p.name)):
            if path.name == "__init__.py" and path.parent == base / package:
                continue
            name = path.relative_to(base / package).as_posix()
            lines.append(f"- `{name}`: {first_sentence(path)}")
        lines.append("")
    return "\n".join(lines)


def main(argv) -> int:
    text = PAGE.read_text()
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    updated = text[:start] + "\n" + layout() + "\n" + text[end:]
    if "--check" in argv:
        if updated != text:
            print(f"{PAGE} is out of date: run python scripts/write_layout.py", file=sys.stderr)
            return 1
        return 0
    PAGE.write_text(updated)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
