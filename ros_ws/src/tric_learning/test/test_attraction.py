"""Prop. 2 measured (tric_learning.analysis.attraction) on hand-made value functions over features
y = q (identity Jacobians): a bowl of sigmoids around the demonstration's end draws the rollouts
back and they come to rest; a linear f has no minimum there, and they run off past f(y_T)."""

import numpy as np
import pytest

from tric_learning.analysis import attraction
from tric_learning.training.dataset import Dataset, Demo
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.world.robot_model import RobotModel


class Identity:
    """phi(q) = q: y (n,) and dy/dq = I."""

    def __call__(self, q, object_poses):
        return np.array(q, dtype=float)

    def with_jacobian(self, q, object_poses):
        return np.array(q, dtype=float), np.eye(len(q))

    def batch(self, configurations, object_poses):
        return np.array(configurations, dtype=float)


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def demo_to(end: np.ndarray) -> Dataset:
    start = end + 0.3
    q = np.linspace(start, end, 5)
    demo = Demo(
        name="to_end",
        situation=None,
        q=q,
        y=q.copy(),
        jacobians=np.repeat(np.eye(len(end))[None], len(q), 0),
        object_poses=[{}] * len(q),
        stamps_ns=np.arange(len(q)),
    )
    return Dataset(None, [demo])


def bowl(end: np.ndarray, width: float = 0.02, steepness: float = 20.0) -> ValueFunction:
    """f = sum_k sigmoid(a (y_k - end_k - w)) + sigmoid(-a (y_k - end_k + w)): flat and lowest
    within w of end in every joint, rising steeply beyond (2n hidden units with biases)."""
    n = len(end)
    w1 = np.vstack([steepness * np.eye(n), -steepness * np.eye(n)])
    b1 = np.concatenate([-steepness * (end + width), steepness * (end - width)])
    scaling = Scaling(np.arange(n), np.zeros(n), np.ones(n), n)
    return ValueFunction(scaling, w1, np.ones(2 * n), np.zeros(n), b1)


def test_a_bowl_at_the_end_draws_the_rollouts_back_to_rest(robot):
    end = (robot.lower + robot.upper) / 2
    dataset = demo_to(end)
    model = bowl(end)
    found = attraction.rollouts_from_demo_ends(
        model, dataset, robot, delta=0.01, rho=50.0, rollouts=3, sigma=0.1, feature_map=Identity()
    )
    assert len(found) == 3 and all(r.demo == 0 for r in found)
    assert all(r.at_rest and r.came_back and r.ticks < attraction.TICKS for r in found)
    numbers = attraction.attraction_numbers(found)
    assert numbers["at_rest"] == numbers["came_back"] == 1.0
    assert numbers["undershoot_max"] < 0.05  # the bowl's floor is as low as the end


def test_a_linear_f_runs_off_past_the_end(robot):
    end = (robot.lower + robot.upper) / 2
    dataset = demo_to(end)
    n = len(end)
    downhill = ValueFunction(
        Scaling(np.arange(n), np.zeros(n), np.ones(n), n), np.zeros((0, n)), np.zeros(0), np.ones(n)
    )
    found = attraction.rollouts_from_demo_ends(
        downhill,
        dataset,
        robot,
        delta=0.01,
        rho=50.0,
        rollouts=2,
        ticks=300,
        feature_map=Identity(),
    )
    assert not any(r.came_back for r in found)
    assert all(r.end_distance > r.start_distance and r.undershoot > 0.5 for r in found)


def test_bad_settings_are_refused(robot):
    end = (robot.lower + robot.upper) / 2
    model, dataset = bowl(end), demo_to(end)
    with pytest.raises(ValueError, match="delta and rho must be positive"):
        attraction.rollouts_from_demo_ends(model, dataset, robot, 0.0, 1.0, feature_map=Identity())
    with pytest.raises(ValueError, match="rollouts and ticks must be at least 1"):
        attraction.rollouts_from_demo_ends(
            model, dataset, robot, 0.01, 1.0, rollouts=0, feature_map=Identity()
        )
