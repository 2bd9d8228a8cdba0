"""DomainDamper: its rows are the gradients of the margins of the features nearest their training
range's bounds (against finite differences of the features), its bounds velocity dampers on those
margins, its unused rows padded. Units: rad; features scaled to [0, 1]."""

import numpy as np
import pytest

from tric_control.limits import UNBOUNDED_BELOW, DomainDamper, StepState
from tric_control.motion_rate import DAMPING, DOMAIN_MARGIN, DOMAIN_ROWS
from tric_control.objectives import Objective, ValueObjective
from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.world.robot_model import RobotModel

SPHERE = {"object": ((0.6, 0.1, 0.3), (0.0, 0.0, 0.0, 1.0))}


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def objective_on_ranges(robot: RobotModel, seed: int) -> ValueObjective:
    """TRIC's objective with a random linear f on all grasp features, each scaled as if the
    demonstrations had spanned a narrow random range around its value at a random configuration
    (so that some features sit near or past their bounds)."""
    rng = np.random.default_rng(seed)
    definition = FeatureDefinition.for_task("grasp", robot)
    features = FeatureMap(definition, robot)
    y = features(rng.uniform(robot.lower, robot.upper), SPHERE)
    kept = np.arange(definition.size)
    low = y - rng.uniform(0.0, 0.2, len(y))
    scaling = Scaling(kept, low, low + 0.2, definition.size)
    value = ValueFunction(
        scaling, np.zeros((0, len(kept))), np.zeros(0), rng.normal(0, 1, len(kept))
    )
    return ValueObjective(features, value, delta=0.01, rho=1.0)


def margins_at(objective: ValueObjective, q, names) -> np.ndarray:
    """The domain margins (>= 0 inside [-DOMAIN_MARGIN, 1 + DOMAIN_MARGIN]) of the named features at
    q."""
    y = objective.features(q, SPHERE)
    index = [objective.kept_names.index(name) for name in names]
    scaling = objective.value_function.scaling
    u = scaling.transform(y)[index]
    return np.minimum(u + DOMAIN_MARGIN, 1.0 + DOMAIN_MARGIN - u)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_rows_are_the_gradients_of_the_nearest_features_margins(robot, seed):
    """The objective's domain rows, which the damper writes, match central finite differences of
    the margins of its DOMAIN_ROWS features, and those are the nearest to their bounds among the
    features a step can move."""
    objective = objective_on_ranges(robot, seed)
    q = np.random.default_rng(seed + 10).uniform(robot.lower, robot.upper)
    model = objective(q, SPHERE)
    state = StepState(max_step=robot.velocity_limits * 0.01, objective=model)
    rows, lower = np.zeros((DOMAIN_ROWS, robot.n_joints)), np.zeros(DOMAIN_ROWS)
    DomainDamper(DOMAIN_ROWS, DAMPING).constrain(state, rows, lower)
    assert np.allclose(
        margins_at(objective, q, model.domain_names), model.domain_margins, atol=1e-12
    )
    h = 1e-6
    numeric = np.array(
        [
            (
                margins_at(objective, q + h * e, model.domain_names)
                - margins_at(objective, q - h * e, model.domain_names)
            )
            / (2 * h)
            for e in np.eye(robot.n_joints)
        ]
    ).T
    assert np.allclose(rows, numeric, atol=1e-6 * max(1.0, np.abs(numeric).max()))
    moving = [
        name
        for name, moves in zip(
            objective.kept_names,
            objective.features.moves_with_q[objective.value_function.scaling.kept],
        )
        if moves
    ]
    assert np.all(
        model.domain_margins <= np.sort(margins_at(objective, q, moving))[DOMAIN_ROWS - 1] + 1e-12
    )


def test_bounds_are_dampers_and_unused_rows_are_padded():
    """lower = min(-damping margin, half of what a step can give along the row) for the objective's
    rows; an objective with fewer rows (a policy: none) leaves the rest padded; a binding row names
    its feature."""
    rows_in = np.array([[1.0, -2.0, 0.0], [0.0, 0.5, 0.5]])
    model = Objective(
        hessian=np.zeros((3, 3)),
        linear=np.zeros(3),
        value=0.0,
        gradient_norm=0.0,
        domain_rows=rows_in,
        domain_margins=np.array([0.01, 0.3]),
        domain_names=["a", "b"],
    )
    max_step = np.array([0.1, 0.1, 0.2])
    limit = DomainDamper(4, DAMPING)
    rows, lower = np.full((4, 3), 9.0), np.full(4, 9.0)
    limit.constrain(StepState(max_step=max_step, objective=model), rows, lower)
    assert np.array_equal(rows[:2], rows_in) and np.all(rows[2:] == 0.0)
    assert np.allclose(lower[:2], [-DAMPING * 0.01, min(-DAMPING * 0.3, 0.5 * (0.05 + 0.1))])
    assert np.all(lower[2:] == UNBOUNDED_BELOW)
    assert limit.active(
        StepState(objective=model), np.zeros(3), np.array([False, True, False, False])
    ) == ["feature_range:b"]
    policy = Objective(
        hessian=np.zeros((3, 3)), linear=np.zeros(3), value=float("nan"), gradient_norm=0.0
    )
    limit.constrain(StepState(max_step=max_step, objective=policy), rows, lower)
    assert np.all(rows == 0.0) and np.all(lower == UNBOUNDED_BELOW)
