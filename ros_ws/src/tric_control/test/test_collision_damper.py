"""CollisionDamper: its rows are the gradients of the pairs'
distances (against finite differences), its bounds the velocity dampers with the safety distance
each pair's contact calls for, its unused rows padded. Units: m, rad."""

from dataclasses import replace

import numpy as np
import pinocchio as pin
import pytest
from closest_samples import hand_made

from tric_control.limits import UNBOUNDED_BELOW, CollisionDamper, ContactRules, StepState
from tric_control.motion_rate import DAMPING, SAFETY, SELF_SAFETY
from tric_sim.world import scene, situations
from tric_sim.world.proximity import Proximity
from tric_sim.world.robot_model import RobotModel

ROWS = 10


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def damper(contacts: dict) -> CollisionDamper:
    return CollisionDamper(ContactRules(contacts), ROWS, SAFETY, SELF_SAFETY, DAMPING)


def distance_of(proximity: Proximity, robot: RobotModel, pair: int, q) -> float:
    """The pair's distance at q, from coal on a geometry data of its own."""
    data = pin.GeometryData(proximity.geometry_model)
    pin.updateGeometryPlacements(
        robot.model, robot.model.createData(), proximity.geometry_model, data, q
    )
    return pin.computeDistance(proximity.geometry_model, data, pair).min_distance


@pytest.mark.parametrize(
    "situation",
    [situations.dataset("sphere_test")[1], situations.dataset("box_test")[2]],
    ids=["sphere", "box"],
)
def test_rows_are_the_gradients_of_the_distances(robot, situation):
    """For the separate pairs near configurations around the object, each row the damper writes
    matches the central finite difference of its pair's distance, joint by joint, to 1e-3 of its
    norm (coal's witness points between a cylinder and a box are that accurate; penetrating pairs,
    whose depth comes from EPA, less so, and are not checked)."""
    proximity = Proximity(robot, situation)
    rng = np.random.default_rng(1)
    above = np.array(situation.object_position) + np.array([0.0, 0.0, 0.15])
    goal = robot.reach(robot.home, "palm_center", pin.SE3(np.eye(3), above))
    limit = damper(proximity.contacts)
    state = StepState(max_step=robot.velocity_limits * 0.01)
    checked, h = 0, 1e-6
    for _ in range(4):
        q = np.clip(goal + rng.normal(0, 0.1, robot.n_joints), robot.lower, robot.upper)
        state.closest = proximity.near(q, {}, 0.05)
        rows, lower = np.zeros((ROWS, robot.n_joints)), np.zeros(ROWS)
        limit.constrain(state, rows, lower)
        assert np.array_equal(rows[: len(state.closest)], state.closest.rows[:ROWS])
        for k, pair in enumerate(state.closest.pairs.tolist()):
            if state.closest.distances[k] <= 0.0:
                continue
            numeric = np.array(
                [
                    (
                        distance_of(proximity, robot, pair, q + h * e)
                        - distance_of(proximity, robot, pair, q - h * e)
                    )
                    / (2 * h)
                    for e in np.eye(robot.n_joints)
                ]
            )
            assert np.abs(state.closest.rows[k] - numeric).max() <= 1e-3 * np.linalg.norm(
                numeric
            ), proximity.pair_names[pair]
            checked += 1
    assert checked >= 8


def test_bounds_are_dampers_with_the_safety_each_pair_calls_for():
    """lower = min(-damping (d - safety), half of what a step can give along the row); the safety is
    SAFETY against the scene, SELF_SAFETY within the robot, and -depth for the hand against a body
    whose contact it holds (not for the arm against it); rows past the pairs are padded."""
    contact = scene.Contact(depth=0.004)
    closest = hand_made(
        [0.002, 0.02, 0.003, 0.001], bodies=[1, 1, 0, -1], hand=[True, False, True, True]
    )
    max_step = np.full(14, 0.01)
    rows, lower = np.full((ROWS, 14), 7.0), np.full(ROWS, 7.0)
    limit = damper({"object": contact})
    limit.constrain(StepState(max_step=max_step, closest=closest), rows, lower)
    margins = np.array([0.002 + 0.004, 0.02 - SAFETY, 0.003 - SAFETY, 0.001 - SELF_SAFETY])
    assert np.allclose(lower[:4], np.minimum(-DAMPING * margins, 0.5 * 0.01))
    assert np.array_equal(rows[:4], np.eye(4, 14))
    assert np.all(rows[4:] == 0.0) and np.all(lower[4:] == UNBOUNDED_BELOW)
    binding = np.zeros(ROWS, dtype=bool)
    binding[[0, 3]] = True
    assert limit.active(StepState(closest=closest), np.zeros(14), binding) == ["pair_0", "pair_3"]


def test_only_the_rows_closest_pairs_are_used():
    """Of more pairs than rows, the first (closest) ROWS make rows."""
    closest = hand_made(
        np.linspace(0.001, 0.04, 12), bodies=[0] * 12, hand=[False] * 12, rows=np.eye(12, 14)
    )
    rows, lower = np.zeros((ROWS, 14)), np.zeros(ROWS)
    damper({}).constrain(StepState(max_step=np.full(14, 1.0), closest=closest), rows, lower)
    assert np.array_equal(rows, np.eye(12, 14)[:ROWS])
    assert np.allclose(lower, -DAMPING * (np.linspace(0.001, 0.04, 12)[:ROWS] - SAFETY))


def upside_down(situation):
    """The situation's box turned over about its x axis, in place: its lid's normal points down."""
    turned = pin.Quaternion(
        scene.se3((0, 0, 0), situation.object_orientation).rotation @ pin.utils.rotate("x", np.pi)
    )
    return replace(
        situation, object_orientation=(turned.x, turned.y, turned.z, turned.w)
    ).validate()


@pytest.mark.parametrize(
    "situation, body, hand_safety",
    [
        (
            situations.dataset("sphere_test")[0],
            "object",
            -scene.TASK_CONTACTS["grasp"]["target"].depth,
        ),
        (
            upside_down(situations.dataset("box_test")[0]),
            "lid",
            -scene.TASK_CONTACTS["open_box"]["lid"].depth,
        ),
        (situations.dataset("box_test")[0], "lid", SAFETY),
        (situations.dataset("box_test")[0], "object", SAFETY),
    ],
    ids=["target", "lid_from_beneath", "lid_from_above", "box_body"],
)
def test_the_task_s_contacts_set_the_hand_s_safety_distance(robot, situation, body, hand_safety):
    """In the real scenes, from the robot's home: the hand may press into a grasp target, and deeper
    into a lid from beneath, keeps SAFETY from a lid it is above (at home, over a closed box) and
    from a box's body; the arm keeps SAFETY from all of them."""
    proximity = Proximity(robot, situation)
    closest = proximity.near(robot.home, {}, 10.0)
    limit = CollisionDamper(
        ContactRules(proximity.contacts), len(closest), SAFETY, SELF_SAFETY, DAMPING
    )
    rows, lower = np.zeros((len(closest), robot.n_joints)), np.zeros(len(closest))
    limit.constrain(StepState(max_step=np.full(robot.n_joints, 1e6), closest=closest), rows, lower)
    # lower = -damping (d - safety) with a huge step bound
    safety = closest.distances + lower / DAMPING
    names = closest.names(slice(None))
    on_body = [k for k, name in enumerate(names) if name.endswith(f"/{body}")]
    hand = {k for k in on_body if closest.hand[k]}
    assert hand and len(hand) < len(on_body)
    assert np.allclose([safety[k] for k in hand], hand_safety)
    assert np.allclose([safety[k] for k in on_body if k not in hand], SAFETY)
