"""The world, as plain data and geometry (no PyBullet, no ROS): the robot's kinematic and collision
model, situations and their data sets and files, the scene's bodies and shapes, the checks that a
situation can physically be, its perturbations, and the collision and proximity queries."""
