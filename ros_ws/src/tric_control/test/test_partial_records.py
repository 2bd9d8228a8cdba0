"""tric-eval's partial results (evaluation.partial.PartialRecords): records kept as they end, each
with the key of all that made it, read back equal (NaN included); a resume keeps exactly the
episodes whose key matches and names each other one with what changed; a file of no run refused."""

import dataclasses
import json
import math
import tracemalloc
from dataclasses import asdict

import pytest

from tric_control.evaluation.partial import (
    PartialRecords,
    agent_digest,
    dropped_line,
    situation_digest,
)
from tric_control.evaluation.records import EpisodeRecord, unjudged_fields
from tric_sim.world import situations

TESTS = [
    situations.sphere(name, (0.55, y, 0.05)) for name, y in (("a", 0.0), ("b", 0.1), ("c", 0.2))
]


def kept(tmp_path, tests=TESTS, agent="teacher", max_steps=0, runs="offline", code="c0"):
    return PartialRecords(tmp_path / "out.json", agent, tests, max_steps, runs, code)


def record(situation) -> EpisodeRecord:
    return EpisodeRecord(
        **unjudged_fields(situation, "teacher"), wall_time_s=1.5, outcome="demonstrated"
    )


def test_partial_records_round_trip_with_their_keys(tmp_path):
    first = kept(tmp_path)
    assert first.resume() == ({}, [])
    first.add(record(TESTS[1]))
    assert math.isnan(record(TESTS[1]).grasp_cost)
    again, dropped = kept(tmp_path).resume()
    assert list(again) == ["b"] and dropped == []
    assert math.isnan(again["b"].grasp_cost) and again["b"].wall_time_s == 1.5
    assert again["b"].outcome == "demonstrated"


#: Why a run through the nodes drops what ran offline (or on another robot).
ANOTHER_WAY = (
    "it ran another way (through the nodes or offline, on another robot, or with other controller "
    "settings)"
)


@pytest.mark.parametrize(
    "change, why",
    [
        ({"agent": "sha256:another"}, "the model changed"),
        ({"max_steps": 300}, "the step budget changed"),
        ({"runs": "nodes"}, ANOTHER_WAY),
        ({"code": "c1"}, "the code changed"),
    ],
)
def test_a_resume_drops_every_episode_whose_run_changed_and_names_why(tmp_path, change, why):
    """The model file replaced by another (its content, not its path), another step budget, the
    nodes instead of offline, changed code: nothing kept is re-used (before: a changed model's
    records were kept and mixed into the result)."""
    first = kept(tmp_path)
    for situation in TESTS[:2]:
        first.add(record(situation))
    done, dropped = kept(tmp_path, **change).resume()
    assert done == {}
    assert dropped == [f"a ({why})", f"b ({why})"]


def test_a_resume_reruns_exactly_the_situations_that_changed(tmp_path):
    """One situation moved by 15 cm, one left out of the run: only the unchanged one is kept, and
    the file then holds only what was kept."""
    first = kept(tmp_path)
    for situation in TESTS:
        first.add(record(situation))
    moved = dataclasses.replace(TESTS[1], object_position=(0.55, 0.25, 0.05))
    assert situation_digest(moved) != situation_digest(TESTS[1])
    resumed = kept(tmp_path, tests=[TESTS[0], moved])
    done, dropped = resumed.resume()
    assert list(done) == ["a"]
    assert dropped == ["b (the situation changed)", "c (not a situation of this run)"]
    assert list(kept(tmp_path, tests=[TESTS[0], moved]).resume()[0]) == ["a"]


def test_the_agent_is_known_by_its_file_s_content(tmp_path):
    one, other = tmp_path / "one.safetensors", tmp_path / "other.safetensors"
    one.write_bytes(b"model one")
    other.write_bytes(b"model one")
    assert agent_digest(one) == agent_digest(other) != agent_digest(None) == "teacher"
    other.write_bytes(b"model two")
    assert agent_digest(one) != agent_digest(other)


def test_files_of_no_run_and_of_an_earlier_tric_eval(tmp_path):
    """A file of no run is refused, naming it; the episodes an earlier tric-eval kept without keys
    are dropped, named."""
    partial = tmp_path / "out.json.partial"
    partial.write_text('{"episodes": [1]}')
    with pytest.raises(ValueError, match="is not a partial run of tric-eval"):
        kept(tmp_path).resume()
    partial.write_text('{"episodes": [{"record": {"situation": "a", "bogus": 1}}]}')
    with pytest.raises(ValueError, match="holds a damaged episode record"):
        kept(tmp_path).resume()
    earlier = {"agent": "teacher", "situations": ["a"], "episodes": [asdict(record(TESTS[0]))]}
    partial.write_text(json.dumps(earlier))
    assert kept(tmp_path).resume() == ({}, ["a (kept without a key, by an earlier tric-eval)"])
    kept(tmp_path).remove()
    assert list(tmp_path.iterdir()) == []


def test_a_sparse_partial_file_is_refused_before_it_is_read_whole(tmp_path):
    """A 300 MB sparse .partial: refused by its size after reading 16 MiB at most (before: read
    whole, a peak of 1 GB)."""
    with open(tmp_path / "out.json.partial", "wb") as file:
        file.truncate(300 * 2**20)
    tracemalloc.start()
    try:
        with pytest.raises(ValueError, match="is larger than 16 MiB"):
            kept(tmp_path).resume()
        peak = tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()
    assert peak < 100 * 2**20


def test_the_dropped_line_names_a_few_and_counts_the_rest():
    assert dropped_line(["a (x)"]) == "1 kept episode made otherwise, run again: a (x)"
    many = [f"s{k} (x)" for k in range(8)]
    assert dropped_line(many).endswith("s4 (x) and 3 more")
