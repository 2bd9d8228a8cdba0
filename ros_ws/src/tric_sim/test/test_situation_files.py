"""Situations files (tric_sim.world.situation_files): the YAML and JSON round trip, bad files
refused with the reason, hostile ones (aliases, deep nesting, size, long input, names that cannot
name a file) refused fast in one short line."""

import json

import pytest
import yaml

from tric_sim.ros.messages import situation_from_msg, situation_to_msg
from tric_sim.tools import untrusted
from tric_sim.world import situations as S
from tric_sim.world.situation import check_name
from tric_sim.world.situation_files import load_situations, save_situations


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
    unknown.write_text(yaml.safe_dump([data]))
    with pytest.raises(ValueError, match="unknown field"):
        load_situations(unknown)


# --- hostile files --------------------------------------------------------------------------------

BILLION_LAUGHS = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
    f"{chr(98 + k)}: &{chr(98 + k)} [{', '.join(['*' + chr(97 + k)] * 9)}]\n" for k in range(8)
)


def test_nested_aliases_are_refused_with_one_short_line(tmp_path):
    path = tmp_path / "laughs.yaml"
    path.write_text(BILLION_LAUGHS + "situations: *i\n")
    with pytest.raises(ValueError, match="aliases are not accepted") as refused:
        load_situations(path)
    assert len(str(refused.value)) < 400 and "\n" not in str(refused.value)


@pytest.mark.parametrize(
    "suffix, text",
    [(".yaml", "[" * 5000 + "]" * 5000), (".yaml", "[" * 40 + "]" * 40), (".json", "[" * 5000)],
)
def test_deep_nesting_is_refused(tmp_path, suffix, text):
    path = tmp_path / ("deep" + suffix)
    path.write_text(text)
    with pytest.raises(ValueError, match="nesting deeper than 32 levels"):
        load_situations(path)


def test_a_file_over_the_size_limit_is_refused_unread(tmp_path, monkeypatch):
    monkeypatch.setattr(untrusted, "MAX_BYTES", 1000)
    path = tmp_path / "big.yaml"
    save_situations(path, S.dataset("obstacle_test")[:4])
    assert path.stat().st_size > 1000
    with pytest.raises(ValueError, match=f"situations file {path} is larger than"):
        load_situations(path)
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"\xff\xfe")
    with pytest.raises(ValueError, match="is not UTF-8 text"):
        load_situations(binary)


LONG = "x" * 100_000


@pytest.mark.parametrize(
    "field, value",
    [
        ("name", LONG),
        ("task", LONG),
        ("object_kind", LONG),
        ("object_position", [LONG, 0.0, 0.3]),
        ("object_dimensions", {LONG: 1}),
        ("obstacles", [{"shape": LONG}]),
        ("obstacles", [{LONG: 1}]),
        (LONG, 1),
    ],
)
def test_errors_quote_at_most_200_characters_of_the_input(tmp_path, field, value):
    data = {**S.sphere("s", (0.6, 0.0, 0.3)).to_dict(), field: value}
    path = tmp_path / "long.yaml"
    path.write_text(yaml.safe_dump([data]))
    with pytest.raises(ValueError) as refused:
        load_situations(path)
    message = str(refused.value)
    assert "x" * 201 not in message and len(message) < 200 + 200 + len(str(path))


def test_yaml_syntax_errors_quote_at_most_200_characters(tmp_path):
    path = tmp_path / "bad.yaml"
    path.write_text("situations: [!" + "t" * 5000 + " 1]\n")
    with pytest.raises(ValueError, match="is not valid YAML") as refused:
        load_situations(path)
    assert "t" * 201 not in str(refused.value)


@pytest.mark.parametrize(
    "name, problem",
    [
        ("a/b", "holds a '/'"),
        ("n" * 129, "is 129 bytes long, over 128"),
        ("é" * 65, "is 130 bytes long, over 128"),
        ("nul\0", "holds a control character or a lone surrogate"),
        ("line\nbreak", "holds a control character or a lone surrogate"),
        ("..", "starts with '.'"),
        (".hidden", "starts with '.'"),
    ],
)
def test_names_that_cannot_name_a_file_are_refused_on_loading(tmp_path, name, problem):
    path = tmp_path / "names.json"
    data = {**S.sphere("s", (0.6, 0.0, 0.3)).to_dict(), "name": name}
    path.write_text(json.dumps([data]))
    with pytest.raises(ValueError, match=f"{problem}: it names the situation's files"):
        load_situations(path)
    msg = situation_to_msg(S.sphere("s", (0.6, 0.0, 0.3)))
    msg.name = name
    with pytest.raises(ValueError, match=problem):
        situation_from_msg(msg)  # as ~/reset_scene reads it


def test_every_built_in_situation_name_names_a_file():
    for dataset in S.DATASETS:
        for situation in S.dataset(dataset):
            assert check_name(situation.name) == situation.name


def test_unknown_names_are_quoted_at_most_80_characters():
    for look_up in (S.dataset, S.find_situation):
        with pytest.raises(ValueError, match=r"'x{80}\.\.\. \(100000 chars\)'"):
            look_up(LONG)


def _sphere_entry(name="s", **changes) -> dict:
    entry = S.sphere(name, (0.55, 0.0, 0.05)).to_dict()
    entry.update(changes)
    return entry


@pytest.mark.parametrize(
    "entry, problem",
    [
        (
            _sphere_entry(object_position=[10**400, 0, 0.2]),
            "situation 's': object_position holds a number too large for a float",
        ),
        (
            _sphere_entry(
                obstacles=[{"shape": "box", "dimensions": [10**400, 1, 1], "position": [1, 0, 0]}]
            ),
            "situation 's': an obstacle's dimensions holds a number too large for a float",
        ),
        (
            _sphere_entry(perturbations=[{"kind": "push", "start_s": 10**400}]),
            "situation 's': bad perturbation entry",
        ),
        (
            _sphere_entry(initial_joint_positions=[3.1] + [0.0] * 6 + [0.1] * 7),
            "situation 's': initial_joint_positions: arm_1_joint = 3.1000 rad is outside its "
            "limits [-2.9671, 2.9671]",
        ),
    ],
)
def test_a_situations_file_is_checked_whole_when_read(tmp_path, entry, problem):
    """Numbers too large for a float (a 400-digit integer: an OverflowError traceback before) and
    a start outside the joint limits (found before only when its episode started, after the
    situations before it had run) are refused when the file is read, naming the file and the
    situation."""
    path = tmp_path / "situations.yaml"
    good = [_sphere_entry("good_1"), _sphere_entry("good_2")]
    path.write_text(yaml.safe_dump({"situations": [*good, entry]}))
    with pytest.raises(ValueError) as refused:
        load_situations(path)
    assert str(refused.value).startswith(f"situations file {path}: {problem}")
    assert len(str(refused.value).splitlines()) == 1


@pytest.mark.parametrize("suffix", [".yaml", ".json"])
def test_a_key_repeated_within_a_situation_is_refused(tmp_path, suffix):
    """Before: the last value silently won."""
    path = tmp_path / ("situations" + suffix)
    entry = json.dumps(_sphere_entry())
    text = '{"situations": [' + entry[:-1] + ', "seed": 7}]}'
    path.write_text(text)
    with pytest.raises(ValueError, match=r"is not valid (YAML|JSON): the key 'seed' repeated"):
        load_situations(path)


def test_names_repeated_in_one_file_are_named(tmp_path):
    path = tmp_path / "situations.yaml"
    path.write_text(yaml.safe_dump({"situations": [_sphere_entry("a"), _sphere_entry("a")]}))
    with pytest.raises(ValueError, match=r"situation names must be unique \(\['a'\] repeat\)"):
        load_situations(path)
