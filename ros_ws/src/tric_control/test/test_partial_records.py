"""tric-eval's partial results (evaluation.PartialRecords): records kept as they end, read back
equal (NaN included), and a file of another run or no run refused."""

import math

import pytest

from tric_control.evaluation.records import EpisodeRecord, PartialRecords, unjudged_fields
from tric_sim.world import situations


def test_partial_records_round_trip_and_refuse_another_run(tmp_path):
    tests = [situations.sphere(name, (0.55, 0.0, 0.05)) for name in ("a", "b", "c")]
    kept = PartialRecords(tmp_path / "out.json", "teacher", tests)
    assert kept.resume() == {}
    record = EpisodeRecord(
        **unjudged_fields(tests[1], "teacher"), wall_time_s=1.5, outcome="demonstrated"
    )
    assert math.isnan(record.grasp_cost)
    kept.add(record)
    again = PartialRecords(tmp_path / "out.json", "teacher", tests).resume()
    assert list(again) == ["b"] and math.isnan(again["b"].grasp_cost)
    assert again["b"].wall_time_s == 1.5 and again["b"].outcome == "demonstrated"
    with pytest.raises(ValueError, match="by another agent"):
        PartialRecords(tmp_path / "out.json", "model.safetensors", tests).resume()
    with pytest.raises(ValueError, match="on other situations"):
        PartialRecords(tmp_path / "out.json", "teacher", tests[:2]).resume()
    (tmp_path / "out.json.partial").write_text('{"episodes": [1]}')
    with pytest.raises(ValueError, match="is not a partial run of tric-eval"):
        kept.resume()
    kept.remove()
    assert list(tmp_path.iterdir()) == []
