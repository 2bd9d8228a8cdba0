"""The compiled objective (tric_control._value_kernel) against the numpy one it replaces in the
controller (ValueObjective with compiled=False, the reference): the same features, Jacobian, value,
gradient and domain rows at random configurations and object poses, for both tasks' feature
definitions and for value functions with and without hidden units; and its refused inputs. Units:
rad, m."""

import numpy as np
import pytest

from tric_control.motion_rate import DOMAIN_ROWS
from tric_control.objectives import COMPILED, ValueObjective
from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def test_the_kernel_is_built():
    """make setup (colcon) builds it; without it the controller falls back to numpy, 3 to 4 times
    slower per objective."""
    assert COMPILED, "tric_control._value_kernel is not built: run make setup (colcon build)"


def random_value_function(definition, feature_map, hidden_units: int, rng) -> ValueFunction:
    """A value function on a random half of the features, with scaling ranges around the values
    the features take near the robot's home and random weights."""
    kept = np.sort(rng.choice(definition.size, definition.size // 2, replace=False))
    low = rng.uniform(-0.5, 0.2, len(kept))
    high = low + rng.uniform(0.2, 1.0, len(kept))
    scaling = Scaling(kept, low, high, definition.size)
    return ValueFunction(
        scaling,
        rng.normal(size=(hidden_units, len(kept))),
        rng.normal(size=hidden_units),
        rng.normal(size=len(kept)),
    )


def object_poses(definition, rng) -> dict:
    """Random poses of the definition's objects, in reach of the robot."""
    poses = {}
    for source in definition.landmark_sources:
        kind, _, name = source.partition("/")
        if kind == "object":
            quaternion = rng.normal(size=4)
            poses[name] = (
                tuple(rng.uniform([0.4, -0.3, 0.3], [0.8, 0.3, 0.6])),
                tuple(quaternion / np.linalg.norm(quaternion)),
            )
    return poses


@pytest.mark.parametrize(
    ("task", "hidden_units"),
    [("grasp", 30), ("grasp", 0), ("open_box", 30), ("grasp", 90)],  # 90: a 3-member ensemble
)
def test_compiled_and_numpy_objectives_agree(robot, task, hidden_units):
    """At 40 random configurations (within the joint limits) and object poses: the quadratic
    model, value, gradient and its norm, the domain rows with their margins and names, and the
    scaled features and df/du the status reads, the same to 1e-12 (relative)."""
    rng = np.random.default_rng(7 + hidden_units)
    definition = FeatureDefinition.for_task(task, robot)
    feature_map = FeatureMap(definition, robot)
    function = random_value_function(definition, feature_map, hidden_units, rng)
    compiled = ValueObjective(feature_map, function, 0.002, 50.0, compiled=True)
    reference = ValueObjective(feature_map, function, 0.002, 50.0, compiled=False)
    for _ in range(40):
        q = rng.uniform(robot.lower, robot.upper)
        poses = object_poses(definition, rng)
        fast, slow = compiled(q, poses), reference(q, poses)
        for name in ("hessian", "linear", "gradient", "domain_rows", "domain_margins"):
            a, b = getattr(fast, name), getattr(slow, name)
            assert a.shape == b.shape, name
            assert np.allclose(a, b, rtol=1e-12, atol=1e-12 * (1 + np.abs(b).max())), name
        assert len(fast.domain_margins) == min(DOMAIN_ROWS, len(reference._moving))
        assert fast.domain_names == slow.domain_names
        assert fast.value == pytest.approx(slow.value, rel=1e-12, abs=1e-12)
        assert fast.gradient_norm == pytest.approx(slow.gradient_norm, rel=1e-12, abs=1e-12)
        assert np.allclose(compiled.scaled_features, reference.scaled_features, atol=1e-12)
        assert np.allclose(compiled.value_gradient, reference.value_gradient, atol=1e-12)


def test_the_kernel_refuses_misshapen_inputs(robot):
    definition = FeatureDefinition.for_task("grasp", robot)
    feature_map = FeatureMap(definition, robot)
    function = random_value_function(definition, feature_map, 3, np.random.default_rng(1))
    kernel = ValueObjective(feature_map, function, 0.002, 50.0, compiled=True)._kernel
    landmarks = len(definition.landmark_names)
    with pytest.raises(ValueError, match=r"placements must be \(L, 4, 4\)"):
        kernel.evaluate(np.zeros((landmarks - 1, 4, 4)), robot.data.J)
    with pytest.raises(ValueError, match=r"joint Jacobian must be \(6, E\)"):
        kernel.evaluate(np.zeros((landmarks, 4, 4)), np.zeros((6, 3)))


def test_compiled_objective_needs_a_feature_map_and_a_value_function(robot):
    """compiled=True with a feature map of another kind: a clear error, not the numpy path."""
    definition = FeatureDefinition.for_task("grasp", robot)
    feature_map = FeatureMap(definition, robot)
    function = random_value_function(definition, feature_map, 3, np.random.default_rng(2))

    class OtherMap:
        moves_with_q, definition = feature_map.moves_with_q, feature_map.definition

    with pytest.raises(ValueError, match="needs tric_control._value_kernel"):
        ValueObjective(OtherMap(), function, 0.002, 50.0, compiled=True)
    assert ValueObjective(OtherMap(), function, 0.002, 50.0)._kernel is None
