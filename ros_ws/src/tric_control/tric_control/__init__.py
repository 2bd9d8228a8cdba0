"""TRIC control: the motion-rate QP controller and its node, the DPL controller, evaluation
episodes, experiment runners, tables and plots."""
