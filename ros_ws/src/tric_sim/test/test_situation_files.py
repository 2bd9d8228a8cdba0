"""Situations files (tric_sim.situation_files): the YAML and JSON round trip, and bad files refused
with the reason."""

import pytest

from tric_sim import situations as S
from tric_sim.situation_files import load_situations, save_situations


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_file_round_trip(tmp_path, suffix):
    original = S.dataset("obstacle_test")[:2] + S.dataset("box_test")[:2]
    path = tmp_path / ("situations" + suffix)
    save_situations(path, original)
    assert load_situations(path) == original


def test_bad_files_are_refused_with_the_reason(tmp_path):
    missing = tmp_path / "nope.yaml"
    with pytest.raises(ValueError, match="cannot read"):
        load_situations(missing)
    garbage = tmp_path / "garbage.json"
    garbage.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        load_situations(garbage)
    unknown = tmp_path / "unknown.yaml"
    data = S.sphere("s", (0.6, 0.0, 0.3)).to_dict()
    data["colour"] = "red"
    import yaml

    unknown.write_text(yaml.safe_dump([data]))
    with pytest.raises(ValueError, match="unknown field"):
        load_situations(unknown)
