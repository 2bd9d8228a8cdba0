"""The report: DIR/REPORT.md from every experiment's JSON in DIR."""

import json
import pathlib

from tric_control.experiments import EXPERIMENT_MODULES, experiment
from tric_control.experiments.checks import check_results, check_table
from tric_sim.output_files import write_text_atomic


def write_report(out: pathlib.Path) -> pathlib.Path:
    """out/REPORT.md from every experiment JSON in out, in the order of EXPERIMENT_MODULES, then the
    design's targets checked against them (checks.py)."""
    lines = [
        "# TRIC experiments",
        "",
        "Written by `tric-experiments` from the JSON files beside this report; each table is ours,",
        "the paper's numbers follow it, then a discussion composed from our numbers.",
        "",
    ]
    results = {}
    for name in EXPERIMENT_MODULES:
        path = out / f"{name}.json"
        if not path.is_file():
            continue
        data = results[name] = json.loads(path.read_text())
        lines += [
            f"## {name}: {experiment(name).TITLE}",
            "",
            "```",
            data["table"],
            "```",
            "",
            f"Paper: {data['paper']}.",
            "",
        ]
        if data.get("discussion"):
            lines += [data["discussion"], ""]
        lines += [f"![{name}]({figure})" for figure in data.get("figures", [f"{name}.png"])]
        lines += ["", f"Run {data['date']} in {data['wall_s']:.0f} s.", ""]
    checks = check_results(results)
    if checks:
        lines += [
            "## The design's targets (docs/design.md section 5), each for every seed",
            "",
            "```",
            check_table(checks),
            "```",
            "",
        ]
    path = out / "REPORT.md"
    write_text_atomic(path, "\n".join(lines))
    return path
