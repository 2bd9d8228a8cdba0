"""The paper's experiments (tric-experiments): one module per experiment, each with its TITLE and
run(runner) (fig9 also takes its situations per shift), returning its rows, table, figure(s), the
paper's numbers (paper.py) and a discussion composed from its numbers; the design's targets
(targets.py); the runner and its model cache (runner.py); the grasp rows shared by the grasp
experiments (rows.py); the report writer (report.py) and the command line (cli.py)."""

import importlib

#: Every experiment's name and module, in the paper's order (the default run and the report's
#: order).
EXPERIMENT_MODULES = {
    "table1": "table1",
    "fig8": "fig8",
    "table2": "table2",
    "fig9": "fig9",
    "table3": "table3",
    "exp4": "exp4",
    "table4": "table4",
    "exp5": "exp5",
    "exp5_wide": "exp5_wide",
    "analysis": "model_analysis",
}


def experiment(name: str):
    """The module of the experiment name, imported when first asked for (the command line answers
    --help before the experiments' libraries load)."""
    return importlib.import_module(f"{__name__}.{EXPERIMENT_MODULES[name]}")
