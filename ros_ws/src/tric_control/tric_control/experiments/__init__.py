"""The paper's experiments (tric-experiments): one module per experiment, each with its TITLE and
run(runner) (fig9 also takes its situations per shift), returning its rows, table, figure(s), the
paper's numbers (paper.py) and a discussion composed from its numbers; the design's targets
(targets.py); the runner and its model cache (runner.py); the grasp rows shared by the grasp
experiments (rows.py); the report writer (report.py) and the command line (cli.py)."""

from tric_control.experiments import (
    exp4,
    fig8,
    fig9,
    model_analysis,
    table1,
    table2,
    table3,
    table4,
)

#: Every experiment by name, in the paper's order (the default run and the report's order).
EXPERIMENTS = {
    "table1": table1,
    "fig8": fig8,
    "table2": table2,
    "fig9": fig9,
    "table3": table3,
    "exp4": exp4,
    "table4": table4,
    "analysis": model_analysis,
}
