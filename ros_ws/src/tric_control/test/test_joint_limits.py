"""JointLimits: the step's box keeps the reference plus the step within the joint limits less the
margin and within the step bound, always allows holding still, and names the joints whose position
bound stops the step. Units: rad (m for a prismatic joint)."""

import numpy as np
import pytest

from tric_control.limits import JointLimits, StepState

LOWER, UPPER = np.array([-1.0, -1.0, -1.0, -2.0]), np.array([1.0, 1.0, 1.0, 2.0])
MARGIN = 0.02
NAMES = ["a", "b", "c", "d"]


def box(reference, max_step):
    limits = JointLimits(LOWER, UPPER, NAMES, MARGIN)
    state = StepState(reference=np.array(reference, float), max_step=np.array(max_step, float))
    low, high = np.full(4, -np.inf), np.full(4, np.inf)
    limits.bound(state, low, high)
    state.low, state.high = low, high
    return limits, state


def test_far_from_the_limits_the_step_bound_is_the_box():
    limits, state = box([0.0, 0.5, -0.5, 1.0], [0.1, 0.1, 0.1, 0.2])
    assert np.array_equal(state.low, -state.max_step) and np.array_equal(state.high, state.max_step)
    assert limits.active(state, state.max_step, np.zeros(0, bool)) == []


def test_near_a_limit_the_box_stops_at_the_margin():
    """0.05 below the upper limit: the step may rise by 0.03 (to the margin) and fall by the full
    step bound; 0.05 above the lower limit, the other way round."""
    limits, state = box([0.95, -0.95, 0.0, 0.0], [0.1, 0.1, 0.1, 0.1])
    assert np.allclose(state.high, [0.03, 0.1, 0.1, 0.1]) and np.allclose(
        state.low, [-0.1, -0.03, -0.1, -0.1]
    )
    step = np.array([0.03, -0.03, 0.05, 0.1])
    assert limits.active(state, step, np.zeros(0, bool)) == ["joint_limit:a", "joint_limit:b"]


def test_outside_the_margin_the_joint_may_hold_but_not_go_further():
    """A reference already within the margin of (or past) a limit: the box holds 0 and allows only
    moves back inside."""
    _, state = box([0.995, -1.01, 0.0, 0.0], [0.1, 0.1, 0.1, 0.1])
    assert state.high[0] == 0.0 and np.isclose(state.low[0], -0.1)
    assert state.low[1] == 0.0 and np.isclose(state.high[1], 0.1)


def test_the_box_only_tightens_what_it_is_given():
    """Bounds tighter than the joint limits' (another limit's) stay."""
    limits = JointLimits(LOWER, UPPER, NAMES, MARGIN)
    state = StepState(reference=np.zeros(4), max_step=np.full(4, 0.1))
    low, high = (
        np.array([-0.01, -np.inf, -np.inf, -np.inf]),
        np.array([np.inf, 0.02, np.inf, np.inf]),
    )
    limits.bound(state, low, high)
    assert np.allclose(low, [-0.01, -0.1, -0.1, -0.1]) and np.allclose(high, [0.1, 0.02, 0.1, 0.1])


def test_each_joint_may_keep_a_margin_of_its_own():
    """Margins per joint (a prismatic joint's in m beside revolute joints' in rad): near its upper
    limit each joint's step stops at its own margin; a negative margin is refused."""
    limits = JointLimits(LOWER, UPPER, NAMES, np.array([0.02, 0.002, 0.02, 0.0]))
    state = StepState(reference=np.array([0.95, 0.95, 0.95, 1.95]), max_step=np.full(4, 0.1))
    low, high = np.full(4, -np.inf), np.full(4, np.inf)
    limits.bound(state, low, high)
    np.testing.assert_allclose(high, [0.03, 0.048, 0.03, 0.05])
    with pytest.raises(ValueError, match="margin must be >= 0"):
        JointLimits(LOWER, UPPER, NAMES, np.array([0.02, -0.001, 0.02, 0.02]))
