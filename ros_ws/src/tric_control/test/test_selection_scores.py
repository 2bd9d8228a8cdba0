"""The selection scores (tric_control.selection.scores) on hand-made rollouts: which distances the
landmark score reads, that a rollout ending where its demonstration ended scores 0 and one off by
the demonstrated motion scores 1, failed rollouts, the judge's scores, and the ranking and
settings around them."""

import math
import re

import numpy as np
import pytest

from tric_control.selection.rollouts import Rollout
from tric_control.selection.scores import (
    LEAST_MOTION,
    demonstrated_motion,
    object_pair_distances,
    per_rollout_errors,
    score,
)
from tric_control.selection.settings import SelectionConfig
from tric_learning.features import FeatureDefinition
from tric_learning.training.dataset import Dataset, Demo
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def definition():
    return FeatureDefinition.for_task("grasp", RobotModel())


def test_the_landmark_score_reads_the_distances_to_the_object(definition):
    """Grasping: the object and the 7 hand landmarks, so 7 distances; box opening: the box and the
    lid to each other and to the fingertips and the base, 7 too."""
    index = object_pair_distances(definition)
    names = [definition.feature_names[k] for k in index]
    assert names == [f"d[object,{name}]" for name in definition.landmark_names[1:]]
    box = FeatureDefinition.for_task("open_box", RobotModel())
    names = [box.feature_names[k] for k in object_pair_distances(box)]
    assert names == [
        "d[box,lid]",
        "d[box,fingertip_2]",
        "d[box,fingertip_3]",
        "d[box,robot_base]",
        "d[lid,fingertip_2]",
        "d[lid,fingertip_3]",
        "d[lid,robot_base]",
    ]


def demos_of(definition, starts, ends) -> Dataset:
    """Demonstrations of two samples each, from starts[i] to ends[i] (features, (d,))."""
    n = len(definition.joint_names)
    return Dataset(
        definition,
        [
            Demo(
                f"demo_{i}",
                None,
                np.zeros((2, n)) + i,
                np.array([start, end]),
                np.zeros((2, definition.size, n)),
                [{}, {}],
                np.arange(2),
            )
            for i, (start, end) in enumerate(zip(starts, ends))
        ],
    )


def rollout(demo, y, q=None, outcome="step_budget", **judged) -> Rollout:
    return Rollout(
        demo.name,
        demo.q[-1] if q is None else q,
        y,
        0.0,
        -1.0,
        800,
        outcome,
        {"success": False, "grasp_cost": math.nan, "lift_passed": None, "lid_angle": math.nan}
        | judged,
    )


def test_a_rollout_off_by_the_demonstrated_motion_scores_one(definition):
    d = definition.size
    index = object_pair_distances(definition)
    starts = [np.full(d, 0.5), np.full(d, 0.5)]
    ends = [np.full(d, 0.3), np.full(d, 0.1)]  # the distances move by 0.2 and 0.4: 0.3 on average
    demos = demos_of(definition, starts, ends)
    motion = demonstrated_motion(demos)
    np.testing.assert_allclose(motion, 0.3)
    exact = [rollout(demo, demo.y[-1]) for demo in demos.demos]
    assert score("landmarks", exact, demos) == 0.0
    off = demos.demos[0].y[-1].copy()
    off[index] += 0.3  # every object distance off by the mean demonstrated motion
    errors = per_rollout_errors("landmarks", [rollout(demos.demos[0], off), exact[1]], demos)
    np.testing.assert_allclose(errors, [1.0, 0.0])
    # a feature the demonstrations keep fixed weighs as a LEAST_MOTION motion
    still = demos_of(definition, [np.zeros(d)], [np.zeros(d)])
    moved = np.zeros(d)
    moved[index[0]] = LEAST_MOTION
    assert score("landmarks", [rollout(still.demos[0], moved)], still) == pytest.approx(
        1.0 / len(index)
    )
    # the other features do not count for the landmark score, they do for "features"
    elsewhere = demos.demos[1].y[-1].copy()
    elsewhere[0] += 1.0
    assert (
        per_rollout_errors("landmarks", [exact[0], rollout(demos.demos[1], elsewhere)], demos)[1]
        == 0.0
    )
    assert score("features", [exact[0], rollout(demos.demos[1], elsewhere)], demos) > 0


def test_a_failed_rollout_is_the_worst_and_rollouts_must_match_the_demonstrations(definition):
    d = definition.size
    demos = demos_of(definition, [np.ones(d)] * 2, [np.zeros(d)] * 2)
    good = rollout(demos.demos[0], np.zeros(d))
    failed = rollout(demos.demos[1], np.full(d, math.nan), outcome="failed")
    for name in ("landmarks", "features", "joints"):
        assert per_rollout_errors(name, [good, failed], demos)[1] == math.inf
        assert score(name, [good, failed], demos) == math.inf
    with pytest.raises(ValueError, match="the rollouts must be those of the dataset's"):
        score("landmarks", [failed, good], demos)
    with pytest.raises(ValueError, match="needs the candidate's value function"):
        score("value", [good, failed], demos)
    with pytest.raises(ValueError, match="unknown selection score 'luck'"):
        score("luck", [good, failed], demos)


def test_the_judge_scores_read_the_hidden_metrics(definition):
    d = definition.size
    demos = demos_of(definition, [np.ones(d)] * 3, [np.zeros(d)] * 3)
    grasped = rollout(demos.demos[0], np.zeros(d), grasp_cost=0.1, lift_passed=True)
    slipped = rollout(demos.demos[1], np.zeros(d), grasp_cost=0.2, lift_passed=False)
    failed = rollout(demos.demos[2], np.zeros(d), outcome="failed")
    rollouts = [grasped, slipped, failed]
    assert score("judge", rollouts, demos) == math.inf  # the failed run
    np.testing.assert_allclose(per_rollout_errors("judge", rollouts, demos)[:2], [0.1, 0.2])
    assert score("successes", rollouts, demos) == -1.0  # only the grasp that held
    opened = rollout(demos.demos[0], np.zeros(d), lid_angle=1.2, success=True)
    assert per_rollout_errors("judge", [opened, slipped, failed], demos)[0] == -1.2


def test_selection_settings_are_checked():
    assert SelectionConfig().validate().score == "landmarks"
    assert not SelectionConfig().uses_judge and SelectionConfig(score="judge").uses_judge
    for settings, message in (
        (SelectionConfig(candidates=0), "candidates must be in [1, 64]"),
        (SelectionConfig(candidates=3, members=4), "members must be in [1, candidates (3)]"),
        (SelectionConfig(score="luck"), "the selection score must be one of"),
    ):
        with pytest.raises(ValueError, match=re.escape(message)):
            settings.validate()
