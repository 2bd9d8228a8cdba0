"""Collision checking of many configurations (tric_sim.world.collision.SceneCollision), the
training's batch check: its mask is the one coal's distances of every pair give, on colliding and
free configurations, and on an empty batch. Units: m, rad."""

import coal
import numpy as np
import pinocchio as pin
import pytest

from tric_sim.world import situations
from tric_sim.world.collision import SceneCollision
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


# --- SceneCollision.collision_free, against coal on every pair -----------------------------------


def colliding_by_coal(collision: SceneCollision, robot: RobotModel, q, object_poses: dict) -> bool:
    """Whether q collides, from coal's distance of every pair (no bounding spheres): a moving robot
    geometry deeper than the allowance into a scene body (placed at object_poses), or two robot
    geometries of a self-collision pair touching."""
    data = robot.model.createData()
    geometry_data = pin.GeometryData(robot.collision_model)
    pin.updateGeometryPlacements(robot.model, data, robot.collision_model, geometry_data, q)
    request, result = coal.DistanceRequest(), coal.DistanceResult()

    def distance(shape, placement, other, other_placement):
        result.clear()
        return coal.distance(
            shape,
            coal.Transform3s(placement.rotation, placement.translation),
            other,
            coal.Transform3s(other_placement.rotation, other_placement.translation),
            request,
            result,
        )

    objects = robot.collision_model.geometryObjects
    for _body, shape, placement, allowance in zip(
        collision.bodies,
        collision.body_shapes,
        collision.body_placements(object_poses),
        collision.allowance,
    ):
        for k, geometry in enumerate(objects):
            if (
                geometry.parentJoint != 0
                and distance(geometry.geometry, geometry_data.oMg[k], shape, placement) < -allowance
            ):
                return True
    return any(
        distance(
            objects[a].geometry, geometry_data.oMg[a], objects[b].geometry, geometry_data.oMg[b]
        )
        < 0
        for a, b in collision.self_pairs
    )


@pytest.mark.parametrize(
    "situation",
    [situations.dataset("sphere_test")[0], situations.dataset("box_test")[0]],
    ids=["sphere", "box"],
)
def test_collision_free_agrees_with_coal_on_every_pair(robot, situation):
    """Random configurations (many collide with the table, the object or the robot itself), the hand
    pushed into the object, the arm swung down onto the table, and home: collision_free's mask is
    the one coal's distances of every pair give, and both kinds of configuration are met."""
    collision = SceneCollision(robot, situation)
    poses = {"object": (situation.object_position, situation.object_orientation)}
    rng = np.random.default_rng(7)
    into_object = robot.reach(
        robot.home, "palm_center", pin.SE3(np.eye(3), np.array(situation.object_position))
    )
    on_table = robot.home.copy()
    on_table[[1, 3]] = 1.9, 0.3
    configurations = np.vstack(
        [
            rng.uniform(robot.lower, robot.upper, (60, robot.n_joints)),
            into_object,
            on_table,
            robot.home,
        ]
    )
    free = collision.collision_free(configurations, poses)
    expected = np.array([not colliding_by_coal(collision, robot, q, poses) for q in configurations])
    assert free.tolist() == expected.tolist()
    assert free[-1] and not free[-2] and not free[-3]
    assert 0 < free.sum() < len(free)


def test_scene_collision_of_home_and_of_an_empty_batch(robot):
    situation = situations.sphere_grid()[13]
    collision = SceneCollision(robot, situation)
    poses = {"object": (situation.object_position, situation.object_orientation)}
    assert collision.collision_free(np.zeros((0, robot.n_joints)), poses).shape == (0,)
    assert collision.collision_free(robot.home[None], poses).tolist() == [True]
