"""The value function's training without ROS (tric_learning.training.samples, training): L-BFGS
lowering the loss, L-BFGS-B's exact zeros, d_curve on a known polyline, refused hyper-parameters,
determinism from a seed, and a training on grid demonstrations whose value function explains them
(decreases along them, gradients against their steps: the design's goals). The loss terms
themselves: test_training_problem.py."""

import math

import numpy as np
import pytest

from tric_learning.analysis import gradient_measures, ranked_features
from tric_learning.analysis.attraction import end_measures
from tric_learning.recording import record_offline
from tric_learning.training import rest
from tric_learning.training.rest import RestRule
from tric_learning.training.samples import d_curve
from tric_learning.training.value import (
    TrainingConfig,
    mean_of_members,
    train,
)
from tric_learning.value_function import ValueFunction
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

#: Landmarks of the hand whose distance to the object the paper found among the top features.
HAND = (
    "palm",
    "fingertip_1",
    "fingertip_2",
    "fingertip_3",
    "finger_mid_1",
    "finger_mid_2",
    "finger_mid_3",
)


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture(scope="module")
def grid_dataset(robot):
    """Seven 5 s sphere demonstrations spread over the 3 x 3 x 3 grid."""
    return record_offline(robot, situations.sphere_grid()[::4], 5.0)


@pytest.fixture(scope="module")
def grid_training(robot, grid_dataset):
    return train(grid_dataset, robot, TrainingConfig())


def test_l_bfgs_lowers_the_loss_from_its_start(robot, grid_dataset):
    """The default optimizer (PyTorch's L-BFGS): the first evaluation is at the initial weights; the
    loss after training is lower."""
    reported = []
    config = TrainingConfig(hidden_units=3, noisy_samples=10, max_iterations=30)
    result = train(
        grid_dataset.subset(3),
        robot,
        config,
        lambda stage, _, losses: reported.append(losses) if stage == "optimizing" else None,
    )
    assert config.optimizer == "lbfgs" and len(reported) >= 2
    assert 1 <= result.iterations <= 30
    assert result.losses["total"] < reported[0]["total"]
    assert min(losses["total"] for losses in reported) == pytest.approx(
        result.losses["total"], rel=1e-5
    )


def test_d_curve_on_a_known_polyline():
    path = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0]])
    points = np.array([[0.5, 0.3], [2.0, 0.5], [-1.0, 0.0], [1.0, 2.0], [0.8, 0.5], [1.0, 0.0]])
    np.testing.assert_allclose(d_curve(points, path), [0.3, 1.0, 1.0, 1.0, 0.2, 0.0], atol=1e-12)
    np.testing.assert_allclose(
        d_curve(points, path[:1]), np.linalg.norm(points, axis=1), atol=1e-12
    )


def test_split_l_bfgs_b_gives_exact_zeros_and_a_lower_loss_than_it_starts_from(robot, grid_dataset):
    demos = grid_dataset.subset(3)
    # the paper's balance of the data terms (alpha_g = 1), so that alpha_w = 0.01 makes the L1 term
    # strong enough against them to zero a quarter of the weights
    config = TrainingConfig(
        hidden_units=3,
        noisy_samples=10,
        max_iterations=30,
        optimizer="lbfgsb",
        alpha_g=1.0,
        alpha_w=0.01,
    )
    reported = []
    result = train(
        demos,
        robot,
        config,
        lambda stage, _, losses: reported.append(losses) if stage == "optimizing" else None,
    )
    weights = np.concatenate([result.model.w1.ravel(), result.model.w2, result.model.w3])
    assert np.sum(weights == 0.0) > weights.size // 4  # the L1 term's solution is sparse
    assert result.losses["total"] < reported[0]["total"] and result.iterations <= 30


@pytest.mark.parametrize(
    "values, message",
    [
        ({"hidden_units": -1}, "hidden_units must be in [0, 1000]"),
        ({"hidden_units": 1001}, "hidden_units must be in [0, 1000]"),
        ({"noisy_samples": 0}, "noisy_samples must be in [1, 10000]"),
        ({"sigma": 0.0}, "sigma must be in (0, 1] rad"),
        ({"sigma": math.nan}, "sigma must be in (0, 1] rad"),
        ({"alpha_n": -1.0}, "alpha_n, alpha_g and alpha_w must be finite and >= 0"),
        ({"alpha_w": math.inf}, "alpha_n, alpha_g and alpha_w must be finite and >= 0"),
        ({"alpha_g": math.nan}, "alpha_n, alpha_g and alpha_w must be finite and >= 0"),
        ({"alpha_n": 0.0, "alpha_g": 0.0}, "alpha_n and alpha_g cannot both be 0"),
        ({"max_iterations": 0}, "max_iterations must be in [1, 100000]"),
        ({"correlation_threshold": 0.0}, "correlation_threshold must be in (0, 1]"),
        ({"correlation_threshold": 1.5}, "correlation_threshold must be in (0, 1]"),
        ({"seed": -1}, "seed must be in [0, 2^32)"),
        ({"seed": 2**32}, "seed must be in [0, 2^32)"),
        ({"optimizer": "adam"}, "optimizer must be one of lbfgs, lbfgsb, bfgs"),
        ({"end_flatness": -1.0}, "end_flatness must be finite and >= 0"),
        ({"end_flatness": math.nan}, "end_flatness must be finite and >= 0"),
    ],
)
def test_training_config_refuses_bad_values(values, message):
    with pytest.raises(ValueError) as refused:
        TrainingConfig(**values).validate()
    assert str(refused.value) == message


def test_training_config_defaults_are_the_papers_but_the_balance():
    """The paper's K, M, sigma, alpha_n and alpha_w; alpha_g and the iterations chosen on the
    training and validation sets (docs/decisions/loss-balance.md)."""
    config = TrainingConfig()
    assert config.validate() is config
    assert (
        config.hidden_units,
        config.noisy_samples,
        config.sigma,
        config.alpha_n,
        config.alpha_w,
    ) == (30, 60, 0.05, 1.0, 0.001)
    assert (config.alpha_g, config.max_iterations) == (30.0, 300)
    assert not config.per_step_weights and config.optimizer == "lbfgs"
    # issue 24's adopted departures (docs/decisions/paper-fidelity.md): L_g on every step weighted
    # by its length, samples that may press 15 mm into the touched body and see the scene of t - 1
    assert (config.lg_min_step, config.lg_weighting) == (0.0, "length")
    assert (config.sample_contact_tolerance, config.sample_scene_step) == (0.015, -1)
    assert not config.hidden_bias and not config.float64 and config.correlation_threshold == 0.995
    # issue 36's hold (noisy samples around each demonstration's end ranked below it) is off, as
    # the paper: pooled over every candidate, no task gained by more than its noise
    assert not config.hold_samples


def test_training_is_determined_by_its_seed(robot, grid_dataset):
    demos = grid_dataset.subset(3)
    config = TrainingConfig(hidden_units=5, noisy_samples=10, max_iterations=5)
    first, again = (train(demos, robot, config) for _ in range(2))
    other = train(
        demos, robot, TrainingConfig(hidden_units=5, noisy_samples=10, max_iterations=5, seed=1)
    )
    for name in ("w1", "w2", "w3"):
        np.testing.assert_array_equal(getattr(first.model, name), getattr(again.model, name))
    assert first.losses == again.losses
    assert not np.array_equal(first.model.w3, other.model.w3)


def test_end_flatness_flattens_f_where_the_demonstrations_end(robot, grid_dataset):
    """L_e (end_flatness > 0) brings f's gradient at the demonstrations' last states well below
    its size along them, which the loss without it leaves steep there; f still falls along every
    demonstration. Measured by the analysis's own end_measures, not by the loss. L_e was studied
    with the hold (docs/decisions/rest-and-grip.md), the default then: with it, to less than half;
    without it (the default since), it still lowers the ratio."""
    demos = grid_dataset.subset(3)
    ratios = {}
    for hold in (True, False):
        for flatness in (0.0, 10.0):
            config = TrainingConfig(
                hidden_units=5,
                noisy_samples=10,
                max_iterations=60,
                end_flatness=flatness,
                hold_samples=hold,
            )
            model = train(demos, robot, config).model
            measures = end_measures(model, demos, robot, count=5)
            ratios[hold, flatness] = measures["end_gradient_ratio"]
            assert all(model.value(d.y[-1]) < model.value(d.y[0]) for d in demos.demos)
    assert ratios[True, 10.0] < 0.5 * ratios[True, 0.0], ratios
    assert ratios[False, 10.0] < ratios[False, 0.0], ratios


def test_a_member_whose_f_does_not_fall_is_left_out_and_named(robot, grid_dataset):
    demos = grid_dataset.subset(3)
    config = TrainingConfig(hidden_units=5, noisy_samples=10, max_iterations=20)
    f = train(demos, robot, config).model
    rising = ValueFunction(f.scaling, f.w1, -f.w2, -f.w3)
    with pytest.warns(RuntimeWarning, match="ensemble member 1 left out: its f does not fall"):
        mean = mean_of_members([f, rising], demos)
    fall = np.mean([f.value(d.y[0]) - f.value(d.y[-1]) for d in demos.demos])
    y = demos.demos[0].y
    np.testing.assert_allclose(mean.value(y), f.value(y) / fall, rtol=1e-12)
    with pytest.raises(ValueError, match="no member of the ensemble learned an f that falls"):
        mean_of_members([rising], demos)


def test_trained_value_function_falls_along_every_demonstration(grid_dataset, grid_training):
    model = grid_training.model
    starts = np.array([model.value(demo.y[0]) for demo in grid_dataset.demos])
    ends = np.array([model.value(demo.y[-1]) for demo in grid_dataset.demos])
    assert np.all(ends < starts)


@pytest.mark.xfail(
    strict=True,
    reason="goal (docs/design.md section 5): mean cosine <= -0.8 over every step that moves at all "
    "(> 1e-3 rad, no filter from the training); measured -0.70 on the 7 grid demonstrations with "
    "TrainingConfig()'s defaults (its cosine weighted by |dq|: -0.87); the slow steps' directions "
    "are not followed (docs/decisions/paper-fidelity.md)",
)
def test_trained_value_function_follows_the_demonstrations(grid_dataset, grid_training):
    """The design's goal (docs/design.md section 5, Fig. 12-17), measured over every step with no
    filter from the training."""
    measures = gradient_measures(grid_training.model, grid_dataset)
    print(f"{measures}; {grid_training.train_time_s:.1f} s")
    assert measures["cosine_moving"] <= -0.8


def test_trained_value_function_falls_on_nine_in_ten_of_the_moving_steps(
    grid_dataset, grid_training
):
    """f falls along 93.5% of the moving steps of the 7 grid demonstrations with TrainingConfig()'s
    defaults on the project's machine. The design's goal, 95%, is a few steps away and another
    CPU's model may reach it or not: it is tracked where the models of the tables are
    (tric-experiments --check, the analysis' targets); here a fall to 90% fails."""
    measures = gradient_measures(grid_training.model, grid_dataset)
    print(f"f decreases on {measures['falls_moving']:.1%} of the moving steps")
    assert measures["falls_moving"] >= 0.90


def test_top_features_include_hand_to_object_distances(grid_dataset, grid_training):
    top = [
        name
        for name, _ in ranked_features(grid_training.model, grid_dataset.definition.feature_names)[
            :10
        ]
    ]
    distances = {f"d[object,{hand}]" for hand in HAND} | {f"d[{hand},object]" for hand in HAND}
    assert distances & set(top), top
    assert 0 < grid_training.selected_features <= len(grid_training.model.scaling.kept)


def test_the_rest_rule_comes_from_the_demonstrations_and_one_from_their_middle_is_refused(
    grid_dataset, grid_training
):
    """The trained model's rest rule: slower than the teacher ever moves over a window on its way,
    f falling at under REST_FALL_SHARE of its pace along the demonstrations; it holds nowhere along
    them while they are still on their way. A rule taken from a demonstration's middle would
    declare rest there: refused, named."""
    model, demos = grid_training.model, grid_dataset
    rule = RestRule.from_dict(grid_training.rest)
    rates = [rest.window_rates(model, demo) for demo in demos.demos]
    slowest = min(float(np.min(speed[left > rest.REST_MARGIN])) for speed, _, left in rates)
    assert rule.speed == pytest.approx(slowest)
    assert rule.window_s == rest.REST_WINDOW_S
    paces = [
        (values[0] - values[-1]) / ((demo.stamps_ns[-1] - demo.stamps_ns[0]) * 1e-9)
        for demo in demos.demos
        for values in [model.value(demo.y)]
    ]
    assert rule.fall == pytest.approx(rest.REST_FALL_SHARE * max(np.median(paces), 0.0))
    assert rule.fall > 0, "f falls along the demonstrations of a trained model"
    rest.check_rest_rule(rule, model, demos)
    speeds, falls, left = rates[0]
    middle = int(np.argmax(left < 0.5))  # half of its way still ahead
    early = RestRule(speed=1.01 * speeds[middle], fall=max(1.01 * falls[middle], 0.0))
    with pytest.raises(ValueError, match="rest comes too early"):
        rest.check_rest_rule(early, model, demos)
    for bad in ({"speed": 0.0, "fall": 0.0, "window_s": 0.25}, {"speed": 1.0}, None):
        with pytest.raises(ValueError):
            RestRule.from_dict(bad)
