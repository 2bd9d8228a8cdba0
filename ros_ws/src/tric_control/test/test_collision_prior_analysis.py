"""tric-analyze's Fig. 14b counts the collision pairs within the controller's influence distance:
tric_learning cannot import tric_control, so it keeps its own copy of that distance."""

from tric_control import motion_rate
from tric_learning import analysis


def test_the_analysis_uses_the_controllers_influence_distance():
    assert analysis.CONTROLLER_INFLUENCE == motion_rate.INFLUENCE
