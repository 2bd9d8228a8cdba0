"""Leaving a stall (tric_control.stall_escape): what a stall is, the walk's goals, the runner
walking out of a rest far above the model's done_value on a hand-made f, and where done_value
comes from (the selection's rollouts) and goes (the objective)."""

import math

import numpy as np
import pytest
from hand_made_values import SPHERE, SPHERE_POSES, palm_minimum_value

from tric_control.episode_runner import EpisodeRunner
from tric_control.motion_rate import MotionRateController
from tric_control.objectives import ValueObjective
from tric_control.selection.choice import done_value
from tric_control.selection.rollouts import Rollout
from tric_control.stall_escape import (
    STALL_SHARE,
    WALK_TICKS,
    StallEscape,
    WalkObjective,
    stalled,
)
from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.training.rest import RestRule
from tric_learning.training.value import TICKS_PER_DEMO
from tric_sim.world.proximity import Proximity
from tric_sim.world.robot_model import RobotModel

DELTA = 0.002


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


class Level:
    """An objective that is only a delta and a done_value (what stalled() reads)."""

    def __init__(self, done_value, delta=DELTA):
        self.done_value, self.delta = done_value, delta


def test_a_stall_is_a_rest_far_above_the_done_value():
    margin = STALL_SHARE * TICKS_PER_DEMO * DELTA
    assert stalled(Level(-1.0), -1.0 + 1.01 * margin)
    assert not stalled(Level(-1.0), -1.0 + 0.99 * margin)
    assert not stalled(Level(-1.0), -5.0)  # below where the rollouts rested: done
    assert not stalled(Level(None), 1e9)  # no selection, no reference: a rest is a rest


def test_the_walk_moves_only_the_arm_within_its_reach_and_limits_the_same_way_each_time(robot):
    escape = StallEscape(escapes=3, rad=0.3, seed=7)
    q = robot.home.copy()
    goals = [escape.goal(q, robot.arm_indices, robot.lower, robot.upper, k) for k in range(3)]
    for goal in goals:
        moved = goal - q
        assert np.all(np.abs(moved[robot.arm_indices]) <= 0.3)
        assert np.count_nonzero(moved[robot.hand_indices]) == 0
        assert np.all((goal >= robot.lower) & (goal <= robot.upper))
    assert not np.array_equal(goals[0], goals[1])  # each walk its own draw
    again = escape.goal(q, robot.arm_indices, robot.lower, robot.upper, 1)
    assert np.array_equal(again, goals[1])
    at_limit = robot.upper.copy()
    goal = escape.goal(at_limit, robot.arm_indices, robot.lower, robot.upper, 0)
    assert np.all(goal <= robot.upper)


@pytest.mark.parametrize(
    "settings, word",
    [
        ({"escapes": -1}, "count"),
        ({"escapes": 1.5}, "count"),
        ({"rad": 0.0}, "reach"),
        ({"rad": math.nan}, "reach"),
        ({"seed": -2}, "seed"),
    ],
)
def test_bad_escape_settings_are_refused_with_a_reason(settings, word):
    with pytest.raises(ValueError, match=word):
        StallEscape(**settings)


def palm_minimum(robot, done: float | None):
    """A controller descending f(u) = u - sigmoid(10 (u + 0.1)) of the palm's scaled distance to a
    sphere u (its minimum at u* about 0.11, f(u*) about -0.78), with done_value done, and the
    sphere's poses."""
    definition = FeatureDefinition.for_task("grasp", robot)
    objective = ValueObjective(
        FeatureMap(definition, robot),
        palm_minimum_value(definition),
        DELTA,
        rho=100.0,
        rest=RestRule(speed=0.01, fall=0.0),
        done_value=done,
    )
    return MotionRateController(robot, Proximity(robot, SPHERE), objective), SPHERE_POSES


def run(robot, done, escapes, max_steps=4000):
    """The runner's episode on palm_minimum (the measured joints follow the commands): the
    runner, its outcome and every command."""
    controller, poses = palm_minimum(robot, done)
    runner = EpisodeRunner(
        robot, controller, max_steps, 0.01, escape=StallEscape(escapes=escapes, seed=3)
    )
    q, commands, outcome = robot.home.copy(), [], None
    while outcome is None:
        decided = runner.step(q, poses)
        q, outcome = decided.command, decided.outcome
        commands.append(q)
    return runner, outcome, np.array(commands)


def test_a_rest_far_above_the_done_value_is_walked_out_of_at_most_escapes_times(robot):
    """done_value far below f's only minimum: every rest there is a stall. The runner walks out of
    it twice (each walk moving the arm, within the velocity bound), descends f again each time,
    and with no walks left ends at rest there; without escapes, or with a done_value the rest
    reaches, the first rest ends the episode."""
    plain, outcome, commands = run(robot, done=-10.0, escapes=0)
    assert outcome[0] == "converged" and plain.stats.walks == 0
    escaping, outcome, walked = run(robot, done=-10.0, escapes=2)
    assert outcome[0] == "converged" and escaping.stats.walks == 2
    assert len(walked) > len(commands) + 2 * 10  # two walks and two descents more
    steps = np.abs(np.diff(walked, axis=0))
    assert np.all(steps <= robot.velocity_limits * 0.01 + 1e-12)
    rest = commands[-1]
    far = np.linalg.norm(walked[:, robot.arm_indices] - rest[robot.arm_indices], axis=1)
    assert far[len(commands) :].max() > 0.1  # it left the rest it first came to
    assert isinstance(escaping.controller.objective, ValueObjective)  # descending f again
    done, outcome, _ = run(robot, done=-0.6, escapes=2)
    assert outcome[0] == "converged" and done.stats.walks == 0


def test_a_walk_ends_at_its_goal_or_after_its_ticks(robot):
    controller, poses = palm_minimum(robot, None)
    goal = robot.home.copy()
    goal[robot.arm_indices] += 0.05
    walk = WalkObjective(controller.objective, goal, robot.velocity_limits * 0.01)
    assert not walk.reached(robot.home) and walk.reached(goal + 0.01)
    controller.objective = walk
    q = robot.home.copy()
    for _ in range(WALK_TICKS):
        q = controller.tick(q, poses).target
        if walk.reached(q):
            break
    assert walk.reached(q)


def rollout(value_end: float, outcome: str = "converged") -> Rollout:
    return Rollout("demo", np.zeros(2), np.zeros(2), 1.0, value_end, 10, outcome, {})


def test_the_done_value_is_the_median_end_of_the_rollouts_that_ran():
    rollouts = [rollout(-3.0), rollout(-1.0), rollout(-2.0), rollout(math.nan, "failed")]
    assert done_value(rollouts) == -2.0
    assert done_value([rollout(math.nan, "failed")]) is None
