"""The asked fall's pace (tric_control.fall_pace): the share of delta it asks on hand-made falls of
f (the controller with it: test_motion_rate.py)."""

import pytest

from tric_control.fall_pace import FallPace

DELTA = 0.002


def shares(pace: FallPace, falls) -> list:
    """The shares asked on ticks whose f fell by falls (a share of DELTA each), from f = 0."""
    state, value, out = pace.start(), 0.0, []
    out.append(state.share(value, DELTA))
    for fall in falls:
        value -= fall * DELTA
        out.append(state.share(value, DELTA))
    return out


def test_f_falling_as_asked_keeps_the_paper_s_step():
    assert shares(FallPace(), [1.0] * 300) == [1.0] * 301


def test_f_that_stops_falling_shrinks_the_ask_to_the_floor_and_back_when_it_falls_again():
    pace = FallPace(knee=0.25, window_ticks=50, floor=0.05)
    stalled = shares(pace, [1.0] * 100 + [0.0] * 400)
    assert stalled[100] == 1.0
    assert all(a >= b for a, b in zip(stalled[100:], stalled[101:]))  # never asks more
    assert stalled[-1] == pytest.approx(0.05)
    # it asks the floor; f falls as much as asked again: the ask grows back to the whole delta
    state, value = pace.start(), 0.0
    for fall in [1.0] * 100 + [0.0] * 400:
        value -= fall * DELTA
        asked = state.share(value, DELTA)
    for _ in range(400):
        value -= asked * DELTA
        asked = state.share(value, DELTA)
    assert asked == 1.0


def test_f_falling_above_the_knee_is_asked_its_whole_delta():
    """f falls at 40% of what is asked: above the knee (25%) the ask stays whole; below it (at a
    knee of 60%) the ask follows down to the floor."""
    assert shares(FallPace(knee=0.25), [0.4] * 400)[-1] == 1.0
    assert shares(FallPace(knee=0.6), [0.4] * 400)[-1] < 1.0


def test_f_rising_counts_as_no_fall():
    assert shares(FallPace(), [-1.0] * 400)[-1] == pytest.approx(FallPace().floor)


@pytest.mark.parametrize(
    "settings, word",
    [
        (dict(knee=0.0), "knee"),
        (dict(knee=1.5), "knee"),
        (dict(knee=float("nan")), "knee"),
        (dict(window_ticks=0.5), "window"),
        (dict(floor=0.0), "floor"),
        (dict(floor=2.0), "floor"),
    ],
)
def test_bad_settings_are_refused_by_name(settings, word):
    with pytest.raises(ValueError, match=word):
        FallPace(**settings)


def test_a_pace_is_asked_only_with_a_knee_and_of_an_objective_that_asks_a_fall():
    """FallPace.for_objective: knee 0 is the paper's constant delta, and an objective without a
    delta (a DPL model's) or with none to ask (0) gets no pace; a TRIC objective gets the knee's."""

    class Objective:
        def __init__(self, delta):
            self.delta = delta

    assert FallPace.for_objective(0.0, Objective(0.3)) is None
    assert FallPace.for_objective(0.25, object()) is None
    assert FallPace.for_objective(0.25, Objective(0.0)) is None
    assert FallPace.for_objective(0.5, Objective(0.3)) == FallPace(knee=0.5)
    with pytest.raises(ValueError, match="knee"):
        FallPace.for_objective(1.5, Objective(0.3))
