"""TRIC learning: task-space features and their Jacobians, MCAP datasets and the recorder node, the
value function, its losses and training, the trainer node, the DPL baseline."""
