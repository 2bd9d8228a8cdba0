"""tric-study: training and controller variants over seeds, measured offline (cli: the command;
runs: the cells and their keys; variants: the tasks, variants and options)."""
