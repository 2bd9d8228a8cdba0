"""What every command-line tool shares, without ROS: its end when interrupted, atomic output files,
input from files treated as hostile, and the provenance (code digest) of its results."""
