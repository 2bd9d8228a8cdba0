"""The top features a controller status carries (tric_control.top_features): ordered by the paper's
score, read from the objective's latest evaluation; none for a policy without a value function."""

import numpy as np

from tric_control.objectives import Objective, ValueObjective
from tric_control.top_features import TopFeatures
from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.world.robot_model import RobotModel

POSES = {"object": (np.array([0.55, 0.05, 0.4]), np.array([0.0, 0.0, 0.0, 1.0]))}


def test_top_features_by_score_with_the_values_and_gradients_of_the_latest_call():
    robot = RobotModel()
    definition = FeatureDefinition.for_task("grasp", robot)
    rng = np.random.default_rng(0)
    kept = np.sort(rng.choice(definition.size, 12, replace=False))
    low, high = rng.uniform(-0.5, 0.0, 12), rng.uniform(0.5, 1.0, 12)
    model = ValueFunction(
        Scaling(kept, low, high, definition.size),
        rng.normal(size=(3, 12)),
        rng.normal(size=3),
        rng.normal(size=12),
    )
    objective = ValueObjective(FeatureMap(definition, robot), model, delta=0.01, rho=1.0)
    top = TopFeatures(objective, count=5)
    assert top.read() == ([], [], [])  # nothing evaluated yet

    q = robot.home + 0.1
    objective(q, POSES)
    names, values, gradients = top.read()
    order = np.argsort(-model.scores())[:5]
    assert names == [definition.feature_names[kept[k]] for k in order]
    assert np.all(np.diff(model.scores()[order]) <= 0)
    u = model.scaling.transform(FeatureMap(definition, robot)(q, POSES))
    assert np.allclose(values, u[order])
    assert np.allclose(gradients, model.scaled_gradient(u)[1][order])


def test_no_features_for_objectives_without_a_value_function():
    class Policy:
        def __call__(self, q, object_poses):
            return Objective(
                hessian=np.eye(14), linear=np.zeros(14), value=float("nan"), gradient_norm=0.0
            )

    assert TopFeatures(Policy()).read() == ([], [], [])
