"""The controller's collision queries (tric_sim.world.proximity.Proximity): it finds every pair
within reach although it sends only some pairs to coal each call (checked against all pairs,
computed directly, along walks with jumps and moving bodies), and the rows of the pairs within the
robot are the gradients of their distances. Units: m, rad."""

import coal
import numpy as np
import pinocchio as pin
import pytest

from tric_sim.world import scene, situations
from tric_sim.world.proximity import Proximity
from tric_sim.world.robot_model import RobotModel

INFLUENCE = 0.05


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def all_close_pairs(proximity: Proximity, robot: RobotModel, q, influence: float) -> dict:
    """{pair index: distance} of every pair of proximity's table within influence at q, each
    computed by coal, on a geometry model and data of their own (the bodies where proximity last put
    them)."""
    model = proximity.geometry_model.copy()
    data = pin.GeometryData(model)
    pin.updateGeometryPlacements(robot.model, robot.model.createData(), model, data, q)
    moving = [
        robot.collision_model.geometryObjects[k].parentJoint != 0
        for k in range(proximity._geometry_count)
    ]
    close = {}
    for pair in range(len(proximity.pair_names)):
        if (
            pair < proximity._geometry_count * proximity._body_count
            and not moving[pair // proximity._body_count]
        ):
            continue  # geometry fixed to the world is not checked against the scene
        distance = pin.computeDistance(model, data, pair).min_distance
        if distance < influence:
            close[pair] = distance
    return close


def check_near(proximity: Proximity, robot: RobotModel, q, poses: dict) -> int:
    """near() at q returns exactly the pairs within reach, with their distances, closest first;
    returns how many."""
    closest = proximity.near(q, poses, INFLUENCE)
    expected = all_close_pairs(proximity, robot, q, INFLUENCE)
    assert sorted(closest.pairs.tolist()) == sorted(expected)
    assert np.allclose(closest.distances, [expected[p] for p in closest.pairs.tolist()], atol=1e-9)
    assert np.all(np.diff(closest.distances) >= 0)
    return len(closest)


@pytest.mark.parametrize(
    "situation, body",
    [(situations.dataset("sphere_test")[0], "object"), (situations.dataset("box_test")[0], "lid")],
    ids=["sphere", "box"],
)
def test_near_finds_every_pair_within_reach_along_a_walk(robot, situation, body):
    """The robot walking towards the object in small steps, jumping now and then; then standing
    still while a body comes towards its hand from 30 cm and turns: at every call near() returns
    exactly the pairs within reach."""
    proximity = Proximity(robot, situation)
    rng = np.random.default_rng(3)
    target = np.array(situation.object_position) + np.array([0.0, 0.0, 0.1])
    goal = robot.reach(robot.home, "palm_center", pin.SE3(np.eye(3), target))
    q, found = robot.home.copy(), 0
    for step in range(40):
        if step % 15 == 14:
            q = rng.uniform(robot.lower, robot.upper)  # a jump
        else:
            q = np.clip(
                q + 0.1 * (goal - q) + rng.normal(0, 0.01, robot.n_joints), robot.lower, robot.upper
            )
        found += check_near(proximity, robot, q, {})
    home = next(b for b in proximity.scene.bodies if b.name == body)
    robot.forward(goal)
    palm = robot.frame_placement("palm_center").translation
    start = np.array(home.position)
    for step in range(31):  # from 30 cm away towards the palm, turning
        position = palm + (start - palm) * (1.0 + (30 - step) * 0.01 / np.linalg.norm(start - palm))
        turn = pin.Quaternion(
            pin.utils.rotate("z", 0.03 * step) @ scene.se3((0, 0, 0), home.orientation).rotation
        )
        near = check_near(
            proximity, robot, goal, {body: (tuple(position), (turn.x, turn.y, turn.z, turn.w))}
        )
    assert found and near, "the walks should come near something"


def test_a_configuration_that_is_not_finite_forgets_nothing(robot):
    """After a NaN configuration, the next finite one gets all its pairs again."""
    situation = situations.dataset("sphere_test")[0]
    proximity = Proximity(robot, situation)
    q = robot.reach(
        robot.home, "palm_center", pin.SE3(np.eye(3), np.array(situation.object_position))
    )
    proximity.near(robot.home, {}, INFLUENCE)
    bad = q.copy()
    bad[3] = np.nan
    proximity.near(bad, {}, INFLUENCE)
    closest = proximity.near(q, {}, INFLUENCE)
    assert sorted(closest.pairs.tolist()) == sorted(all_close_pairs(proximity, robot, q, INFLUENCE))
    assert len(closest)


def test_self_collision_rows_are_the_gradients_of_the_distances(robot):
    """At random configurations, each pair within the robot that near() returns (arm geometries near
    other robot geometries, separate) has the row of its distance's gradient in q: the central
    finite difference of coal's distance, joint by joint, to 1e-3 of its norm (as the scene pairs'
    rows in test_collision_damper); the joints that move neither side or both together have a zero
    entry."""
    proximity = Proximity(robot, situations.dataset("sphere_test")[0])
    geometry_data = pin.GeometryData(proximity.geometry_model)
    # GJK to 1e-10 m: coal's default 1e-6 is too coarse for h
    for pair in range(len(proximity.pair_names)):
        geometry_data.distanceRequests[pair] = coal.DistanceRequest()
        geometry_data.distanceRequests[pair].gjk_tolerance = 1e-10
    data = robot.model.createData()

    def distance(pair, q):
        pin.updateGeometryPlacements(robot.model, data, proximity.geometry_model, geometry_data, q)
        return pin.computeDistance(proximity.geometry_model, geometry_data, pair).min_distance

    rng = np.random.default_rng(11)
    checked, h = 0, 1e-6
    for _ in range(12):
        q = rng.uniform(robot.lower, robot.upper)
        closest = proximity.near(q, {}, INFLUENCE)
        for k in np.flatnonzero((closest.bodies == -1) & (closest.distances > 0.0)):
            pair = int(closest.pairs[k])
            numeric = np.array(
                [
                    (distance(pair, q + h * e) - distance(pair, q - h * e)) / (2 * h)
                    for e in np.eye(robot.n_joints)
                ]
            )
            assert np.abs(closest.rows[k] - numeric).max() <= 1e-3 * np.linalg.norm(numeric), (
                closest.pair_names[pair]
            )
            assert not closest.hand[k]
            checked += 1
    assert checked >= 5
