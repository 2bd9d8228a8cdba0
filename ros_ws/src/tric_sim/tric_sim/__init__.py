"""The world of TRIC: the robot model (URDF, Pinocchio, coal), scenes and situations, the PyBullet
simulator node, the teachers and the hidden task metrics."""
