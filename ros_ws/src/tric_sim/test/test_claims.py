"""One writer per output (tric_sim.tools.claims), the final move that never replaces a file that
appeared meanwhile (output_files.atomic_path), results readable as any new file, and the names a
run will make checked all together (tric_sim.tools.file_names)."""

import contextlib
import errno
import os
import subprocess
import sys

import pytest

from tric_sim.tools import claims, file_names, output_files
from tric_sim.tools.claims import FOLDER_LOCK, claim, lock_path, open_exclusive

#: Seconds a helper process may take to start and hold its claim (it takes well under one).
START_S = 60.0


@contextlib.contextmanager
def held_elsewhere(path, folder: bool = False):
    """Another process holding a claim on path (or an open_exclusive file, with folder None) for
    the duration of the block; its PID."""
    if folder is None:
        hold = f"f = open_exclusive({str(path)!r}, 'file')"
    else:
        hold = f"c = claim({str(path)!r}, folder={folder})"
    code = (
        "import sys\nfrom tric_sim.tools.claims import claim, open_exclusive\n"
        f"{hold}\nprint('held', flush=True)\nsys.stdin.read()\n"
    )
    process = subprocess.Popen(
        [sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    try:
        assert process.stdout.readline() == "held\n"
        yield process.pid
    finally:
        process.stdin.close()
        process.wait(timeout=START_S)


def test_a_claim_refuses_a_second_run_naming_the_first_one_s_pid(tmp_path):
    out = tmp_path / "r.json"
    with held_elsewhere(out) as pid:
        assert lock_path(out).read_text() == f"{pid}\n"
        with pytest.raises(ValueError) as refused:
            claim(out, "--json file")
        assert str(refused.value) == (
            f"--json file {out} is being written by another run (PID {pid}): wait for it to "
            "end, or give another path"
        )
    with claim(out, "--json file"):  # the first run ended: its claim went with it
        assert lock_path(out).read_text() == f"{os.getpid()}\n"
    assert list(tmp_path.iterdir()) == []


def test_a_claim_left_by_a_killed_run_claims_nothing(tmp_path):
    """The kernel releases the lock of a process however it ends: SIGKILL leaves the lock file,
    which the next run takes over."""
    out = tmp_path / "m.safetensors"
    code = (
        "import os, signal\nfrom tric_sim.tools.claims import claim\n"
        f"claim({str(out)!r})\nos.kill(os.getpid(), signal.SIGKILL)\n"
    )
    killed = subprocess.run([sys.executable, "-c", code], timeout=START_S)
    assert killed.returncode == -9 and lock_path(out).exists()
    with claim(out):
        pass
    assert list(tmp_path.iterdir()) == []


def test_claims_are_counted_within_a_process_and_folders_they_made_removed(tmp_path):
    """A tool and the library code it calls may both claim one output; the last release removes
    the lock file, and the folders the claim made when they stayed empty."""
    out = tmp_path / "new" / "deeper" / "bags"
    first = claim(out, "--out", folder=True)
    second = claim(out, "--out", folder=True)
    assert (out / FOLDER_LOCK).is_file() and claims.held_locks() == [out / FOLDER_LOCK]
    second.release()
    second.release()  # once only
    assert (out / FOLDER_LOCK).is_file()
    first.release()
    assert list(tmp_path.iterdir()) == [] and claims.held_locks() == []
    with claim(out, "--out", folder=True):
        (out / "kept.mcap").write_bytes(b"a bag")
    assert sorted(p.name for p in out.iterdir()) == ["kept.mcap"]


def test_a_folder_claim_refuses_a_second_run_and_makes_nothing(tmp_path):
    out = tmp_path / "bags"
    with held_elsewhere(out, folder=True) as pid:
        with pytest.raises(ValueError, match=rf"--out {out} is being written .*\(PID {pid}\)"):
            claim(out, "--out", folder=True)
    assert list(tmp_path.iterdir()) == [out]
    assert list(out.iterdir()) == []


def test_a_file_written_in_place_is_one_writer_s(tmp_path):
    """A bag's .part: a second writer is refused naming the first one's PID (from /proc/locks)."""
    part = tmp_path / "a.mcap.part"
    with held_elsewhere(part, folder=None) as pid:
        with pytest.raises(FileExistsError, match=rf"bag {part} is being written .*\(PID {pid}\)"):
            open_exclusive(part, "bag")
    with open_exclusive(part, "bag") as file:
        file.write(b"mine")
    assert part.read_bytes() == b"mine"


def test_the_final_move_never_replaces_a_file_that_appeared_meanwhile(tmp_path):
    """replace False (no --overwrite): a file another program wrote while the run worked is left
    as it was, the result goes beside it, and the error names both."""
    path = tmp_path / "r.json"
    with pytest.raises(output_files.WriteFailed) as failed:
        with output_files.atomic_path(path, replace=False) as temporary:
            temporary.write_text("this run's result")
            path.write_text("another program's")
    assert failed.value.errno == errno.EEXIST
    assert str(failed.value) == (
        f"{path} appeared while this run worked (another program wrote it): it is left as it "
        f"was, and this run's result is {tmp_path / 'r.new.json'}"
    )
    assert path.read_text() == "another program's"
    assert (tmp_path / "r.new.json").read_text() == "this run's result"
    output_files.write_text_atomic(path, "replaced")  # replace True: --overwrite
    assert path.read_text() == "replaced"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["r.json", "r.new.json"]


def test_a_rename_without_replacing_falls_back_to_a_link(tmp_path, monkeypatch):
    """Where the C library or the file system has no renameat2, a hard link does the same."""
    monkeypatch.setattr(output_files, "_renameat2", lambda: (None, None))
    source, target = tmp_path / "a", tmp_path / "b"
    source.write_text("a")
    target.write_text("b")
    with pytest.raises(FileExistsError):
        output_files.rename_without_replacing(source, target)
    target.unlink()
    output_files.rename_without_replacing(source, target)
    assert target.read_text() == "a" and not source.exists()


def test_results_are_readable_as_any_new_file(tmp_path):
    """Under umask 0022 a result is 0644 whatever wrote its temporary file (safetensors wrote model
    files 0600, while JSON got 0644)."""
    previous = os.umask(0o022)
    try:
        with output_files.atomic_path(tmp_path / "m.safetensors") as temporary:
            descriptor = os.open(temporary, os.O_CREAT | os.O_WRONLY, 0o600)
            os.close(descriptor)
        assert (tmp_path / "m.safetensors").stat().st_mode & 0o777 == 0o644
    finally:
        os.umask(previous)


def test_names_that_map_to_one_file_are_refused_before_work(tmp_path, monkeypatch):
    stems = {name: file_names.safe_stem(name) + ".mcap" for name in ("grasp a", "grasp_a")}
    with pytest.raises(ValueError) as refused:
        file_names.check_file_names(tmp_path, stems, "bag")
    assert str(refused.value) == (
        f"the bags of 'grasp a' and 'grasp_a' would be one file, {tmp_path}/grasp_a.mcap: "
        "rename one"
    )
    assert file_names.safe_stem("grasp:a") == "grasp_a" and file_names.safe_stem("") == "episode"
    distinct = {"Grasp": "Grasp.mcap", "grasp": "grasp.mcap"}
    file_names.check_file_names(tmp_path, distinct, "bag")  # this file system tells case apart
    monkeypatch.setattr(file_names, "name_folding", lambda folder: (True, False))
    with pytest.raises(ValueError, match="would be one file, .*/grasp.mcap \\(Grasp.mcap to its"):
        file_names.check_file_names(tmp_path, distinct, "bag")
    monkeypatch.setattr(file_names, "name_folding", lambda folder: (False, True))
    with pytest.raises(ValueError, match="would be one file"):
        file_names.check_file_names(tmp_path, {"a": "\u00e9.png", "b": "e\u0301.png"}, "picture")
    assert list(tmp_path.iterdir()) == []


def test_a_file_system_s_name_folding_is_found_by_trying(tmp_path):
    """tmp_path's file system (Linux: case and Unicode forms kept apart) says so, and the probe
    leaves nothing."""
    assert file_names.name_folding(tmp_path / "not" / "made") == (False, False)
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize(
    "files, reason",
    [
        ({"x": ".x.mcap"}, "hidden by its leading dot"),
        ({"x": "x" * 250 + ".mcap"}, "bytes the file system takes"),
        ({"x": "input.yaml"}, "is an input of this run"),
    ],
)
def test_hidden_long_and_input_names_are_refused(tmp_path, files, reason):
    (tmp_path / "input.yaml").write_text("situations: []")
    with pytest.raises(ValueError, match=reason):
        file_names.check_file_names(tmp_path, files, "bag", inputs=(tmp_path / "input.yaml",))


def test_the_file_names_check_creates_nothing(tmp_path):
    file_names.check_file_names(tmp_path / "new", {"a": "a.png", "b": "b.png"}, "picture")
    assert list(tmp_path.iterdir()) == []
