"""Test-session set-up shared by every test: an isolated DDS domain, no display, and reproducible
fuzzing (hypothesis)."""

import os

from hypothesis import settings

# The fuzz tests (each sets its own bounded max_examples) draw the same examples on every run and
# keep no example database in the work tree; HYPOTHESIS_PROFILE=explore draws new ones each run.
settings.register_profile("ci", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False, database=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))


def pytest_configure(config):
    # A DDS domain of its own for this test run (0..101 are valid with Fast DDS defaults; 0 is left
    # to the user), discovery limited to this machine, and no display for anything that could open
    # one.
    os.environ["ROS_DOMAIN_ID"] = str(1 + os.getpid() % 100)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.pop("DISPLAY", None)
    os.environ.setdefault("MPLBACKEND", "Agg")
