"""The asked fall's pace (tric_control.fall_pace): the share of delta it asks on hand-made falls of
f, and the controller with it where the world follows its steps and where it does not."""

import numpy as np
import pytest

from tric_control.fall_pace import FallPace
from tric_control.motion_rate import MotionRateController
from tric_control.objectives import Objective, ValueObjective
from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.world import situations
from tric_sim.world.proximity import Proximity
from tric_sim.world.robot_model import RobotModel

DELTA = 0.002


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


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


def palm_distance_objective(robot: RobotModel) -> ValueObjective:
    """f = the palm's scaled distance to the object, asked to fall by DELTA a tick."""
    definition = FeatureDefinition.for_task("grasp", robot)
    kept = np.array([definition.feature_names.index("d[palm,object]")])
    value_function = ValueFunction(
        Scaling(kept, np.array([0.25]), np.array([1.0]), definition.size),
        np.zeros((0, 1)),
        np.zeros(0),
        np.array([1.0]),
    )
    return ValueObjective(FeatureMap(definition, robot), value_function, DELTA, rho=100.0)


def run(robot, pace, blocked_from: int, ticks: int = 400):
    """The steps' norms of a controller descending palm_distance_objective towards a sphere; from
    tick blocked_from on the measured joints no longer follow the command (the robot is held)."""
    situation = situations.sphere("sphere", (0.55, 0.0, 0.45))
    poses = {"object": (situation.object_position, situation.object_orientation)}
    objective = palm_distance_objective(robot)
    controller = MotionRateController(robot, Proximity(robot, situation), objective, fall_pace=pace)
    q, norms, values = robot.home.copy(), [], []
    for k in range(ticks):
        tick = controller.tick(q, poses)
        norms.append(float(np.linalg.norm(tick.step)))
        values.append(tick.value)
        if k < blocked_from:
            q = tick.target
    return np.array(norms), np.array(values)


def test_the_controller_keeps_the_paper_s_descent_while_the_world_follows(robot):
    paced, values = run(robot, FallPace(), blocked_from=10**6, ticks=150)
    plain, plain_values = run(robot, None, blocked_from=10**6, ticks=150)
    np.testing.assert_array_equal(paced, plain)
    assert (values[0] - values[100]) / 100 == pytest.approx(DELTA, rel=0.1)


def test_a_held_robot_s_steps_shrink_with_the_pace_and_not_without_it(robot):
    """Held from tick 100 (f stops falling): the paper's controller asks the same step on and on;
    with the pace the step shrinks to a small share of it within a few windows."""
    paced, _ = run(robot, FallPace(knee=0.25, window_ticks=50, floor=0.05), blocked_from=100)
    plain, _ = run(robot, None, blocked_from=100)
    assert plain[-1] == pytest.approx(plain[150], rel=1e-6) and plain[-1] > 0
    assert paced[-1] < 0.1 * plain[-1]
    np.testing.assert_array_equal(paced[:100], plain[:100])


def test_a_pace_needs_an_objective_that_asks_a_fall(robot):
    class NoFall:
        def __call__(self, q, object_poses):
            n = len(q)
            return Objective(np.zeros((n, n)), np.zeros(n), 0.0, 0.0)

    situation = situations.sphere("sphere", (0.55, 0.0, 0.45))
    with pytest.raises(ValueError, match="delta"):
        MotionRateController(robot, Proximity(robot, situation), NoFall(), fall_pace=FallPace())
