"""The physics (PyBullet): the simulated world stepped in control periods (simulation), the scene's
bodies built in it, and the hidden task metrics that judge its state."""
