"""The model analyses of tric_learning.analysis (paper Fig. 13, 14a, 16, 17a) on hand-made value
functions and demonstrations, where every number is known: features y = q (identity Jacobians), so
grad_q (f o phi) = df/dy."""

import warnings
from types import SimpleNamespace

import numpy as np
import pytest

from tric_learning import analysis
from tric_learning.dataset import Dataset, Demo
from tric_learning.value_function import Scaling, ValueFunction


def demo(name: str, q) -> Demo:
    """A demo whose features are its joints (y = q, dy/dq = I)."""
    q = np.asarray(q, dtype=float)
    return Demo(name=name, situation=None, q=q, y=q.copy(), jacobians=np.repeat(np.eye(q.shape[1])[None], len(q), 0),
                object_poses=[{}] * len(q), stamps_ns=np.arange(len(q)))


def dataset(*demos) -> Dataset:
    """The demos with two named features (no feature definition is needed beyond the names)."""
    return Dataset(SimpleNamespace(feature_names=("a", "b")), list(demos))


def linear(w3, low=None, high=None) -> ValueFunction:
    """f = w3 . u with u = (y - low) / (high - low) on every feature (K = 0)."""
    w3 = np.asarray(w3, dtype=float)
    low = np.zeros(len(w3)) if low is None else np.asarray(low, dtype=float)
    high = np.ones(len(w3)) if high is None else np.asarray(high, dtype=float)
    return ValueFunction(Scaling(np.arange(len(w3)), low, high, len(w3)), np.zeros((0, len(w3))), np.zeros(0), w3)


def test_cosines_on_straight_lines_against_along_and_across_the_gradient():
    model = linear([1.0, 2.0])                                     # grad f = (1, 2) everywhere
    down = demo("down", [[0.0, 0.0], [-0.05, -0.1], [-0.15, -0.3], [-0.15, -0.3]])  # the last step rests
    up_then_across = demo("up", [[0.0, 0.0], [0.05, 0.1], [0.25, 0.0]])            # (0.2, -0.1) is orthogonal
    cosines = analysis.cosines_along_demos(model, dataset(down, up_then_across))
    assert cosines.shape == (2, 3)
    np.testing.assert_allclose(cosines[0, :2], [-1.0, -1.0], atol=1e-12)
    np.testing.assert_allclose(cosines[1, :2], [1.0, 0.0], atol=1e-12)
    assert np.isnan(cosines[0, 2]) and np.isnan(cosines[1, 2])    # a zero step; past the shorter demo's end
    moving = analysis.cosines_along_demos(model, dataset(down, up_then_across), min_step=0.15)
    assert np.isnan(moving[0, 0]) and moving[0, 1] == pytest.approx(-1.0)  # |(0.05, 0.1)| < 0.15 < |(0.1, 0.2)|
    assert np.isnan(moving[1, 0]) and moving[1, 1] == pytest.approx(0.0, abs=1e-12)


def test_cosines_use_the_recorded_jacobian_and_the_scaling():
    model = linear([1.0, 0.0], low=[0.0, 0.0], high=[4.0, 1.0])   # df/dy = (1/4, 0)
    rotated = demo("rotated", [[0.0, 0.0], [0.0, -0.3]])
    rotated.jacobians[0] = [[0.0, 1.0], [-1.0, 0.0]]              # y_0 = q_1: grad_q = (0, 1/4)
    cosines = analysis.cosines_along_demos(model, dataset(rotated))
    assert cosines[0, 0] == pytest.approx(-1.0)


def test_gradients_along_demos_are_constant_for_a_linear_model_and_known_for_one_unit():
    gradients = analysis.gradients_along_demos(linear([1.0, -2.0], high=[2.0, 1.0]), dataset(
        demo("long", [[0.0, 0.0], [0.5, 0.1], [1.0, 0.2]]), demo("short", [[0.3, 0.3], [0.1, 0.2]])))
    assert gradients.shape == (2, 3, 2)
    np.testing.assert_allclose(gradients[0], [[1.0, -2.0]] * 3)   # df/du = W3 (the paper's K = 0 remark)
    np.testing.assert_allclose(gradients[1, :2], [[1.0, -2.0]] * 2)
    assert np.all(np.isnan(gradients[1, 2]))
    one_unit = ValueFunction(Scaling(np.arange(2), np.zeros(2), np.ones(2), 2), np.array([[1.0, 0.0]]),
                             np.array([2.0]), np.array([1.0, -2.0]))
    [[at_zero]] = analysis.gradients_along_demos(one_unit, dataset(demo("zero", [[0.0, 0.0]])))
    np.testing.assert_allclose(at_zero, [1.0 + 2.0 * 0.25, -2.0])  # W3 + W1^T (W2 sigmoid'(0))


def test_mean_over_demos_skips_missing_entries_without_warning():
    values = np.array([[1.0, np.nan, 2.0], [3.0, np.nan, np.nan]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mean = analysis.mean_over_demos(values)
    np.testing.assert_allclose(mean, [2.0, np.nan, 2.0])
    np.testing.assert_allclose(analysis.mean_over_demos(np.ones((2, 3, 4))), np.ones((3, 4)))


def test_key_numbers_of_a_model_that_explains_one_demo_and_not_another():
    model = linear([1.0, 2.0])
    good = demo("good", [[0.0, 0.0], [-0.1, -0.2], [-0.2, -0.4], [-0.2, -0.4]])
    bad = demo("bad", [[0.0, 0.0], [0.1, 0.2], [0.2, 0.4], [0.2, 0.4]])
    numbers = analysis.key_numbers(model, dataset(good, bad), top=1)
    assert numbers["steps"] == 6 and numbers["moving_steps"] == 4 and numbers["demos_ending_lower"] == 1
    assert numbers["decreasing_share_moving_steps"] == pytest.approx(0.5)
    assert numbers["decreasing_share_all_steps"] == pytest.approx(2 / 6)
    assert numbers["mean_cosine_moving_steps"] == pytest.approx(0.0, abs=1e-12)   # two -1 and two +1
    assert numbers["late_from_step"] == 2 and np.isnan(numbers["mean_cosine_moving_late"])  # both rest at the end
    assert numbers["kept_features"] == 2 and numbers["selected_features"] == 2
    assert numbers["top_features"] == [{"name": "b", "score": 2.0}]
    assert numbers["top_gradients_changing_sign"] == 0


def test_score_order_and_a_gradient_that_changes_sign():
    # f = u_0 - 4 sigmoid(4 u_0) + 0.1 u_1: df/du_0 = 1 - 16 sigmoid'(4 u_0), < 0 at u_0 = 0, > 0 at u_0 = 1
    model = ValueFunction(Scaling(np.arange(2), np.zeros(2), np.ones(2), 2), np.array([[4.0, 0.0]]),
                          np.array([-4.0]), np.array([1.0, 0.1]))
    np.testing.assert_array_equal(analysis.score_order(model), [0, 1])
    numbers = analysis.key_numbers(model, dataset(demo("along", [[0.0, 0.0], [0.5, 0.0], [1.0, 0.0]])), 2)
    assert numbers["top_gradients_changing_sign"] == 1


def test_figures_are_written(tmp_path):
    model = linear([1.0, 2.0])
    demos = dataset(demo("one", [[0.0, 0.0], [-0.1, -0.2], [-0.2, -0.3]]), demo("two", [[0.1, 0.0], [0.0, -0.1]]))
    paths = analysis.write_figures(model, demos, tmp_path / "figures", top=2)
    assert [path.name for path in paths] == [analysis.VALUE_FIGURE, analysis.COSINES_FIGURE, analysis.SCORES_FIGURE,
                                             analysis.GRADIENTS_FIGURE]
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
