"""tric-analyze's Fig. 14b counts the collision pairs within the controller's influence distance,
and its Prop. 2 rollouts rest by the controller's criterion: tric_learning cannot import
tric_control, so it keeps its own copies of both."""

from tric_control import motion_rate
from tric_learning import analysis
from tric_learning.analysis import attraction


def test_the_analysis_uses_the_controllers_influence_distance():
    assert analysis.CONTROLLER_INFLUENCE == motion_rate.INFLUENCE


def test_the_attraction_analysis_rests_by_the_controller_s_criterion():
    """tric_learning.analysis.attraction copies the controller's convergence criterion (it may not
    import tric_control)."""
    assert (attraction.REST_WINDOW, attraction.REST_MOTION) == (
        motion_rate.CONVERGED_WINDOW,
        motion_rate.CONVERGED_MOTION,
    )
