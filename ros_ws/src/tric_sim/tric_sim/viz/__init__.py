"""What viewers show: the scene as solid primitives in frames, its ROS messages for RViz, the live
Foxglove view and the tools' --viz options, and pictures of situations."""
