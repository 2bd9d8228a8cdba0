"""Test-session set-up shared by every test: an isolated DDS domain, no display, reproducible
fuzzing (hypothesis), and a native stack dump of a test that hangs."""

import os
import shutil
import subprocess
import sys
import threading

import pytest
from hypothesis import settings

# The fuzz tests (each sets its own bounded max_examples) draw the same examples on every run and
# keep no example database in the work tree; HYPOTHESIS_PROFILE=explore draws new ones each run.
settings.register_profile("ci", derandomize=True, database=None)
settings.register_profile("explore", derandomize=False, database=None)
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

#: Seconds before pytest-timeout's limit (pytest.ini) at which a still-running test's threads are
#: dumped with their native frames: pytest-timeout then prints the Python frames only, and a hang
#: below Python (DDS, rcl, a solver) needs the C/C++ frames and locks to be found.
NATIVE_DUMP_LEAD_S = 60.0


def pytest_configure(config):
    # A DDS domain of its own for this test run (0..101 are valid with Fast DDS defaults; 0 is left
    # to the user), discovery limited to this machine, and no display for anything that could open
    # one.
    os.environ["ROS_DOMAIN_ID"] = str(1 + os.getpid() % 100)
    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    os.environ.pop("DISPLAY", None)
    os.environ.setdefault("MPLBACKEND", "Agg")


def dump_native_stacks(nodeid: str) -> None:
    """Print every thread of this process with its native and Python frames (py-spy) to stderr
    (fd 2: pytest captures it with the test, and pytest-timeout prints it when it ends the run)."""
    spy = shutil.which("py-spy", path=os.path.dirname(sys.executable)) or shutil.which("py-spy")
    print(f"\n+++ {nodeid} still runs: native stacks of every thread +++", file=sys.__stderr__)
    if spy is None:
        print("(py-spy not found: no native stacks)", file=sys.__stderr__, flush=True)
        return
    try:
        dump = subprocess.run(
            [spy, "dump", "--native", "--pid", str(os.getpid())],
            capture_output=True,
            text=True,
            timeout=NATIVE_DUMP_LEAD_S / 2,
        )
        text = dump.stdout + dump.stderr
    except (OSError, subprocess.SubprocessError) as error:
        text = f"(py-spy failed: {error})"
    print(text, file=sys.__stderr__, flush=True)


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_protocol(item, nextitem):
    limit_s = float(item.config.getini("timeout") or 0.0)
    timer = None
    if limit_s > NATIVE_DUMP_LEAD_S:
        timer = threading.Timer(limit_s - NATIVE_DUMP_LEAD_S, dump_native_stacks, (item.nodeid,))
        timer.daemon = True
        timer.start()
    try:
        yield
    finally:
        if timer is not None:
            timer.cancel()
