"""The scene's geometry and rules (tric_sim.world.scene): the contacts each task allows, as the
collision models take them."""

import pytest

from tric_sim.world import scene, situations
from tric_sim.world.collision import CONTACT_TOLERANCE
from tric_sim.world.proximity import Proximity
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def test_the_task_s_contacts_come_with_the_scene(robot):
    """The grasp target and the lid are the bodies the hand may press (scene.TASK_CONTACTS); the
    training's collision check lets every robot geometry into them by CONTACT_TOLERANCE."""
    sphere, box = situations.dataset("sphere_test")[0], situations.dataset("box_test")[0]
    assert scene.contacts(sphere) == {"object": scene.TASK_CONTACTS["grasp"]["target"]}
    assert scene.contacts(box) == {"lid": scene.TASK_CONTACTS["open_box"]["lid"]}
    for situation in (sphere, box):
        proximity = Proximity(robot, situation)
        assert proximity.contacts == scene.contacts(situation)
        allowance = dict(zip(proximity.body_names, proximity.scene.allowance))
        assert allowance == {
            name: CONTACT_TOLERANCE if name in proximity.contacts else 0.0
            for name in proximity.body_names
        }
