"""SIGINT and SIGTERM to the tools run as commands (issue 25, item 2): each ends with one line and
exit status 130 or 143, every finished bag complete, the unfinished one only as .part, an earlier
bag never replaced by a cut-short one, and no result file written half."""

import os
import signal
import subprocess
import sys

import pytest

from conftest import HANG_S
from tric_learning.bags.info import bag_info


def start(module: str, *arguments) -> subprocess.Popen:
    """The tool's module run as a command (argv from the command line), its stderr piped."""
    return subprocess.Popen(
        [sys.executable, "-m", module, *arguments],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONFAULTHANDLER": "1"},
    )


def signal_after(process: subprocess.Popen, marker: str, count: int, signum: int) -> tuple:
    """Send signum once marker has appeared count times on the tool's stderr (read line by line:
    the wait ends on the event); (exit status, the rest of stderr)."""
    seen = 0
    for text in process.stderr:
        seen += marker in text
        if seen >= count:
            break
    assert seen >= count, f"the tool ended before {count} x {marker!r}"
    process.send_signal(signum)
    rest = process.communicate(timeout=HANG_S)[1]
    return process.returncode, rest


@pytest.mark.parametrize(
    "signum, status, word",
    [(signal.SIGINT, 130, "interrupted"), (signal.SIGTERM, 143, "terminated")],
)
def test_tric_record_interrupted_keeps_finished_bags_and_leaves_the_rest_as_part(
    tmp_path, signum, status, word
):
    out = tmp_path / "bags"
    recorder = start("tric_learning.record_cli", "sphere_train", "--out", str(out))
    code, rest = signal_after(recorder, "wrote ", 2, signum)
    assert code == status, rest
    lines = [line for line in rest.splitlines() if line.startswith("tric-record:")]
    assert lines == [f"tric-record: {word}; the bags of the finished demonstrations kept"], rest
    assert "Traceback" not in rest and "Fatal Python error" not in rest
    finished = sorted(out.glob("*.mcap"))
    assert len(finished) >= 2
    for bag in finished:
        assert bag_info(bag).complete
    assert all(p.suffix in (".mcap", ".part") for p in out.iterdir())
    assert len(list(out.glob("*.part"))) <= 1


def test_tric_record_overwrite_terminated_keeps_the_earlier_bag(tmp_path):
    """--overwrite replaces a bag only once its successor is complete: a demonstration cut short
    leaves the earlier bag as it was, the new one as .part."""
    out = tmp_path / "bags"
    first = start("tric_learning.record_cli", "sphere_train", "--out", str(out))
    code, rest = signal_after(first, "wrote ", 3, signal.SIGINT)
    assert code == 130, rest
    earlier = sorted(bag.name for bag in out.glob("*.mcap"))
    again = start("tric_learning.record_cli", "sphere_train", "--out", str(out), "--overwrite")
    code, rest = signal_after(again, "demonstrating ", 1, signal.SIGTERM)
    assert code == 143, rest
    assert "tric-record: terminated; the bags of the finished demonstrations kept" in rest
    assert set(earlier) <= {bag.name for bag in out.glob("*.mcap")}
    for bag in out.glob("*.mcap"):
        assert bag_info(bag).complete, bag


def test_tric_eval_interrupted_writes_no_json_and_ends_its_workers(tmp_path):
    out = tmp_path / "teacher.json"
    evaluation = start(
        "tric_control.evaluate_cli", "--teacher", "sphere_test", "--json", str(out), "--jobs", "2"
    )
    code, rest = signal_after(evaluation, "demonstrating ", 2, signal.SIGTERM)
    assert code == 143, rest
    assert "tric-eval: terminated; no records written" in rest
    assert "Traceback" not in rest and "Fatal Python error" not in rest
    assert list(tmp_path.iterdir()) == []  # no JSON, no temporary file
