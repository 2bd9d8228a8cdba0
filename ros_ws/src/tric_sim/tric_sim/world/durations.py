"""How long the teachers demonstrate, simulated s: by task unless told otherwise (DEFAULT_DURATION),
and at most (MAX_DURATION: the teacher node refuses a longer demonstration, and tric-record a
longer --duration, before any work). ROS-free and light: the tools check their arguments with it
before the libraries load."""

#: Demonstration lengths by task, simulated s (the paper: 5 s grasps; 80 plan steps of 0.1 s).
DEFAULT_DURATION = {"grasp": 5.0, "open_box": 8.0}
#: The longest demonstration, simulated s (a bag of that length takes about 7 MB).
MAX_DURATION = 120.0
