"""The value function f(y) = z^T W2 + y^T W3, z = sigmoid(W1 u), on the features rescaled to
[0, 1] (tric_learning.value_function): its gradient in y, and grad_q (f o phi) through the features'
Jacobian, against finite differences."""

import numpy as np
import pytest

from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def random_value_function(rng, scaling: Scaling, hidden_units: int) -> ValueFunction:
    s = len(scaling.kept)
    return ValueFunction(
        scaling,
        rng.normal(0, 2, (hidden_units, s)),
        rng.normal(0, 1, hidden_units),
        rng.normal(0, 1, s),
    )


def central_difference(function, x: np.ndarray, step: float) -> np.ndarray:
    """d function / dx (x.shape) by central differences."""
    gradient = np.zeros_like(x)
    for k in range(len(x)):
        offset = np.zeros_like(x)
        offset[k] = step
        gradient[k] = (function(x + offset) - function(x - offset)) / (2 * step)
    return gradient


@pytest.mark.parametrize("hidden_units", [0, 4])
def test_value_gradient_matches_finite_differences(hidden_units):
    rng = np.random.default_rng(3)
    scaling = Scaling(
        kept=np.array([0, 2, 3, 6]), low=rng.uniform(-1, 0, 4), high=rng.uniform(0.5, 2, 4), size=8
    )
    model = random_value_function(rng, scaling, hidden_units)
    y = rng.uniform(-1, 2, 8)
    value, gradient = model.gradient(y)
    assert value == pytest.approx(float(model.value(y)), abs=1e-12)
    assert gradient.shape == (8,) and np.all(gradient[[1, 4, 5, 7]] == 0)
    np.testing.assert_allclose(
        gradient, central_difference(model.value, y, 1e-6), rtol=1e-6, atol=1e-8
    )


def test_gradient_of_value_over_features_matches_finite_differences(robot):
    """grad_q (f o phi) = (df/dy)(dphi/dq) (Eq. 10) with the analytic feature Jacobian."""
    rng = np.random.default_rng(4)
    feature_map = FeatureMap(FeatureDefinition.for_task("grasp", robot), robot)
    poses = {"object": (np.array([0.55, 0.1, 0.85]), np.array([0.0, 0.0, 0.0, 1.0]))}
    around = robot.home + rng.normal(0, 0.2, (50, robot.n_joints))
    scaling = Scaling.fit(np.array([feature_map(q, poses) for q in around]), 0.995)
    model = random_value_function(rng, scaling, 6)
    q = robot.home + rng.normal(0, 0.1, robot.n_joints)
    y, jacobian = feature_map.with_jacobian(q, poses)
    analytic = model.gradient(y)[1] @ jacobian
    numeric = central_difference(lambda x: float(model.value(feature_map(x, poses))), q, 1e-6)
    np.testing.assert_allclose(analytic, numeric, rtol=1e-5, atol=1e-6 * np.abs(numeric).max())


def test_an_ensemble_is_the_weighted_sum_of_its_members():
    rng = np.random.default_rng(5)
    scaling = Scaling(
        kept=np.array([1, 2, 5]), low=rng.uniform(-1, 0, 3), high=rng.uniform(0.5, 2, 3), size=6
    )
    members = [random_value_function(rng, scaling, units) for units in (4, 0, 2)]
    weights = [0.5, -2.0, 1.5]
    ensemble = ValueFunction.ensemble(members, weights)
    assert ensemble.hidden_units == 6
    for y in rng.uniform(-1, 2, (5, 6)):
        value, gradient = ensemble.gradient(y)
        parts = [member.gradient(y) for member in members]
        assert value == pytest.approx(sum(w * v for w, (v, _) in zip(weights, parts)), abs=1e-12)
        np.testing.assert_allclose(
            gradient, sum(w * g for w, (_, g) in zip(weights, parts)), atol=1e-12
        )


def test_an_ensemble_refuses_other_scalings_and_bad_weights():
    rng = np.random.default_rng(6)
    scaling = Scaling(kept=np.array([0, 1]), low=np.zeros(2), high=np.ones(2), size=3)
    other = Scaling(kept=np.array([0, 1]), low=np.zeros(2), high=np.full(2, 2.0), size=3)
    first, second = (random_value_function(rng, s, 2) for s in (scaling, other))
    with pytest.raises(ValueError, match="must share one Scaling"):
        ValueFunction.ensemble([first, second], [1.0, 1.0])
    with pytest.raises(ValueError, match="needs as many finite weights"):
        ValueFunction.ensemble([first, first], [1.0])
    with pytest.raises(ValueError, match="needs as many finite weights"):
        ValueFunction.ensemble([first, first], [1.0, np.nan])
    with pytest.raises(ValueError, match="at least one member"):
        ValueFunction.ensemble([], [])


@pytest.mark.parametrize("hidden_units", [0, 3])
def test_a_value_function_on_a_wider_scaling_is_the_same_f_less_a_constant(hidden_units):
    rng = np.random.default_rng(5)
    first = Scaling(np.array([0, 2, 5]), rng.uniform(-1, 0, 3), rng.uniform(0.5, 2, 3), 8)
    second = Scaling(np.array([2, 3]), rng.uniform(-2, -1, 2), rng.uniform(1, 3, 2), 8)
    union = Scaling.union([first, second])
    assert union.kept.tolist() == [0, 2, 3, 5]
    assert union.low[1] == min(first.low[1], second.low[0])
    assert union.high[1] == max(first.high[1], second.high[0])
    model = random_value_function(rng, first, hidden_units)
    model.b1 = rng.normal(0, 1, hidden_units)
    moved = model.on_scaling(union)
    ys = rng.uniform(-1, 2, (20, 8))
    differences = moved.value(ys) - model.value(ys)
    np.testing.assert_allclose(differences, differences[0], atol=1e-12)
    for y in ys[:3]:
        np.testing.assert_allclose(moved.gradient(y)[1], model.gradient(y)[1], atol=1e-12)
    with pytest.raises(ValueError, match="must keep every feature"):
        model.on_scaling(second)
    with pytest.raises(ValueError, match="at least one scaling"):
        Scaling.union([])
