"""The optimization problem of TRIC's training (tric_learning.training.problem): each loss term on a
hand-made case (L_e, the end's flatness, too), the loss's gradient in the weights (gradcheck), and
L_n's per-step weights."""

import math

import numpy as np
import pytest
import torch

from tric_learning.training.dataset import Dataset, Demo
from tric_learning.training.problem import TrainingProblem
from tric_learning.training.samples import NoisySamples
from tric_learning.training.value import TrainingConfig
from tric_learning.value_function import Scaling


def test_loss_terms_on_a_hand_made_case():
    """One demo of 4 steps in 2 features and 2 joints, f = 2 sigmoid(u_0) + u_0 - 2 u_1 with
    u = (y_0 / 2, y_1): every term of Eq. 11 worked out by hand."""
    q = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, 0.1], [0.1, 0.1]])  # the last step does not move
    y = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [1.0, 1.0]])
    jacobians = np.array([np.eye(2), [[0.0, -1.0], [1.0, 0.0]], np.eye(2), np.eye(2)])
    demo = Demo(
        name="hand",
        situation=None,
        q=q,
        y=y,
        jacobians=jacobians,
        object_poses=[{}] * 4,
        stamps_ns=np.arange(4),
    )
    noisy = NoisySamples(
        step=np.array([1, 2, 3]),
        y=np.array([[0.0, 0.5], [2.0, 0.0], [1.0, 1.0]]),
        weight=np.array([2.0, 0.5, 1.0]),
        kept_per_step=np.array([0, 1, 1, 1]),
    )
    scaling = Scaling(kept=np.array([0, 1]), low=np.zeros(2), high=np.array([2.0, 1.0]), size=2)
    problem = TrainingProblem(Dataset(None, [demo]), noisy, scaling, TrainingConfig(hidden_units=1))
    # W1 = (1, 0), W2 = 2, W3 = (1, -2)
    theta = torch.tensor([1.0, 0.0, 2.0, 1.0, -2.0])
    loss_n, loss_g, loss_w, loss_e = (float(term) for term in problem.terms(theta))

    sigmoid = lambda x: 1.0 / (1.0 + math.exp(-x))  # noqa: E731
    softplus = lambda x: math.log1p(math.exp(x))  # noqa: E731
    f1 = 2 * sigmoid(0.5) + 0.5  # u = (0.5, 0); f0 = 1
    f2 = f1 - 2  # u = (0.5, 1), and f3 = f2
    noisy_f = [0.0, 2 * sigmoid(1.0) + 1.0, f2]  # u = (0, 0.5), (1, 0), (0.5, 1)
    expected_n = (
        2.0 * softplus(f1 - noisy_f[0]) + 0.5 * softplus(f2 - noisy_f[1]) + 1.0 * math.log(2.0)
    )
    # df/dy = ((2 sigmoid'(u_0) + 1) / 2, -2); steps 0 and 1 move, along q_0 and q_1
    dfdy0 = (2 * 0.25 + 1) / 2  # u_0 = 0
    dfdy0_next = (2 * sigmoid(0.5) * (1 - sigmoid(0.5)) + 1) / 2
    cos_0 = dfdy0 / math.hypot(dfdy0, 2.0)  # grad_q = (dfdy0, -2) . (1, 0)
    # grad_q = (-2, -dfdy0_next) . (0, 1)
    cos_1 = -dfdy0_next / math.hypot(dfdy0_next, 2.0)
    assert loss_n == pytest.approx(expected_n, rel=1e-5)
    assert loss_g == pytest.approx(cos_0 + cos_1, rel=1e-5)
    assert loss_w == pytest.approx(6.0, rel=1e-6)
    assert loss_e == 0.0  # off by default: not computed


def hand_made_problem(config: TrainingConfig, second_step: float = 0.1) -> TrainingProblem:
    """The demo and scaling of test_loss_terms_on_a_hand_made_case, with one noisy sample; the
    second step second_step rad along q_1."""
    q = np.array([[0.0, 0.0], [0.1, 0.0], [0.1, second_step], [0.1, second_step]])
    y = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [1.0, 1.0]])
    jacobians = np.array([np.eye(2), [[0.0, -1.0], [1.0, 0.0]], np.eye(2), np.eye(2)])
    demo = Demo("hand", None, q, y, jacobians, [{}] * 4, np.arange(4))
    noisy = NoisySamples(
        step=np.array([1]), y=np.array([[0.0, 0.5]]), weight=np.ones(1), kept_per_step=np.ones(4)
    )
    scaling = Scaling(kept=np.array([0, 1]), low=np.zeros(2), high=np.array([2.0, 1.0]), size=2)
    return TrainingProblem(Dataset(None, [demo]), noisy, scaling, config)


def test_l_e_is_the_ends_squared_gradient_over_its_mean_square_along_the_way():
    """The hand-made f with end_flatness 2: grad_q f at the last state (u = (0.5, 1), the identity
    Jacobian scaled by (1/2, 1)) is (dfdy0_next, -2); along the two moving steps it is (dfdy0, -2)
    and (-2, -dfdy0_next). L_e is the first's square over the mean of the others', and the loss
    the optimizer sees adds it times end_flatness."""
    sigmoid = lambda x: 1.0 / (1.0 + math.exp(-x))  # noqa: E731
    dfdy0 = (2 * 0.25 + 1) / 2
    dfdy0_next = (2 * sigmoid(0.5) * (1 - sigmoid(0.5)) + 1) / 2
    end = dfdy0_next**2 + 4
    along = ((dfdy0**2 + 4) + (4 + dfdy0_next**2)) / 2
    theta = torch.tensor([1.0, 0.0, 2.0, 1.0, -2.0])
    flat = hand_made_problem(TrainingConfig(hidden_units=1, end_flatness=2.0))
    plain = hand_made_problem(TrainingConfig(hidden_units=1))
    assert float(flat.terms(theta)[3]) == pytest.approx(end / along, rel=1e-5)
    added = float(flat._data_loss(theta)[0]) - float(plain._data_loss(theta)[0])
    assert added == pytest.approx(2.0 * end / along, rel=1e-5)


@pytest.mark.parametrize("weighting", ["length", "none"])
def test_l_g_weighs_each_step_by_its_length_over_the_mean(weighting):
    """The hand-made case with steps of unequal length: 0.1 rad along q_0, then 0.3 rad along q_1.
    The directions, hence the cosines, are those of the case above; weighted by length (the
    default, docs/decisions/paper-fidelity.md) the cosines count 0.1 / 0.2 and 0.3 / 0.2 times,
    unweighted (Eq. 11) once each."""
    config = TrainingConfig(hidden_units=1, lg_weighting=weighting)
    problem = hand_made_problem(config, second_step=0.3)
    loss_g = float(problem.terms(torch.tensor([1.0, 0.0, 2.0, 1.0, -2.0]))[1])
    sigmoid = lambda x: 1.0 / (1.0 + math.exp(-x))  # noqa: E731
    dfdy0 = (2 * 0.25 + 1) / 2
    dfdy0_next = (2 * sigmoid(0.5) * (1 - sigmoid(0.5)) + 1) / 2
    cos_0 = dfdy0 / math.hypot(dfdy0, 2.0)
    cos_1 = -dfdy0_next / math.hypot(dfdy0_next, 2.0)
    weights = (0.5, 1.5) if weighting == "length" else (1.0, 1.0)
    assert loss_g == pytest.approx(weights[0] * cos_0 + weights[1] * cos_1, rel=1e-5)
    assert abs((0.5 * cos_0 + 1.5 * cos_1) - (cos_0 + cos_1)) > 0.1  # the weighting shows


def random_problem(config: TrainingConfig, seed: int = 5) -> TrainingProblem:
    """The loss of a made-up dataset: one demo of 6 steps in 4 features and 3 joints, every step
    moving (0.1 rad per joint), random recorded Jacobians, and 3 noisy samples at each step t >=
    1."""
    rng = np.random.default_rng(seed)
    steps, features, joints = 6, 4, 3
    q = np.cumsum(np.full((steps, joints), 0.1), axis=0)
    demo = Demo(
        name="random",
        situation=None,
        q=q,
        y=rng.uniform(0, 1, (steps, features)),
        jacobians=rng.normal(0, 1, (steps, features, joints)),
        object_poses=[{}] * steps,
        stamps_ns=np.arange(steps),
    )
    noisy_step = np.repeat(np.arange(1, steps), 3)
    noisy = NoisySamples(
        step=noisy_step,
        y=rng.uniform(0, 1, (len(noisy_step), features)),
        weight=rng.uniform(0.1, 1.0, len(noisy_step)),
        kept_per_step=np.r_[0, np.full(steps - 1, 3)],
    )
    scaling = Scaling(
        kept=np.arange(features), low=np.zeros(features), high=np.ones(features), size=features
    )
    return TrainingProblem(Dataset(None, [demo]), noisy, scaling, config)


@pytest.mark.parametrize("hidden_units", [0, 3])
def test_loss_gradient_in_the_weights_passes_gradcheck(hidden_units):
    """d(L_n, L_g, |w|_1, L_e)/dw, as autograd computes it for L-BFGS, against finite differences
    in float64 (torch.autograd.gradcheck), at random weights (none at |w|_1's kink 0). The lbfgsb
    configuration builds the problem in float64; its loss terms are the ones lbfgs minimizes."""
    config = TrainingConfig(hidden_units=hidden_units, optimizer="lbfgsb", end_flatness=1.0)
    problem = random_problem(config)
    assert problem.u.dtype == torch.float64
    theta = torch.tensor(
        np.random.default_rng(6).normal(0, 1, problem.theta.numel()),
        dtype=torch.float64,
        requires_grad=True,
    )
    assert torch.autograd.gradcheck(
        lambda weights: torch.stack(problem.terms(weights)),
        (theta,),
        eps=1e-6,
        atol=1e-6,
        rtol=1e-5,
    )


def test_per_step_weights_make_each_steps_l_n_a_weighted_mean():
    """The hand-made case of test_loss_terms_on_a_hand_made_case with two samples at step 1: summed
    (Eq. 16) their weights add up; per step they are divided by their sum."""
    q = np.array([[0.0, 0.0], [0.1, 0.0], [0.2, 0.0]])
    demo = Demo(
        name="hand",
        situation=None,
        q=q,
        y=q * 10,
        jacobians=np.array([np.eye(2)] * 3),
        object_poses=[{}] * 3,
        stamps_ns=np.arange(3),
    )
    noisy = NoisySamples(
        step=np.array([1, 1, 2]),
        y=np.array([[0.0, 0.5], [2.0, 0.0], [1.0, 1.0]]),
        weight=np.array([3.0, 1.0, 0.5]),
        kept_per_step=np.array([0, 2, 1]),
    )
    scaling = Scaling(kept=np.array([0, 1]), low=np.zeros(2), high=np.array([2.0, 1.0]), size=2)
    theta = torch.tensor([1.0, -2.0])  # linear: f = u_0 - 2 u_1
    softplus = lambda x: math.log1p(math.exp(x))  # noqa: E731
    f = lambda y: y[0] / 2 - 2 * y[1]  # noqa: E731
    contrasts = [softplus(f(demo.y[step]) - f(sample)) for step, sample in zip(noisy.step, noisy.y)]
    summed = TrainingProblem(
        Dataset(None, [demo]), noisy, scaling, TrainingConfig(hidden_units=0)
    ).terms(theta)[0]
    mean = TrainingProblem(
        Dataset(None, [demo]), noisy, scaling, TrainingConfig(hidden_units=0, per_step_weights=True)
    ).terms(theta)[0]
    assert float(summed) == pytest.approx(
        3.0 * contrasts[0] + 1.0 * contrasts[1] + 0.5 * contrasts[2], rel=1e-5
    )
    assert float(mean) == pytest.approx(
        0.75 * contrasts[0] + 0.25 * contrasts[1] + contrasts[2], rel=1e-5
    )
