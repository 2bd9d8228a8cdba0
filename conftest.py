"""Test-session set-up shared by every test: an isolated DDS domain and no display."""

import os


def pytest_configure(config):
    # A DDS domain of its own for this test run (0..101 are valid with Fast DDS defaults; 0 is left to
    # the user), discovery limited to this machine, and no display for anything that could open one.
    os.environ["ROS_DOMAIN_ID"] = str(1 + os.getpid() % 100)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.pop("DISPLAY", None)
    os.environ.setdefault("MPLBACKEND", "Agg")
