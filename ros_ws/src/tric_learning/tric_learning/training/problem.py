"""The optimization problem of TRIC's training (paper Sec. 3.2, Eq. 11, 16 and 17): the loss as a
torch function of the value function's flattened weights, built from a dataset, its noisy samples
and the feature scaling, and its minimization by PyTorch's L-BFGS (the default), by SciPy's
L-BFGS-B on the weights split into positive and negative parts (exact L1), or by SciPy's BFGS in
float64 (the paper's optimizer).

L_g sums over every step of the demonstrations (those shorter than the config's lg_min_step left
out, none by default; a step of length zero has no direction and adds nothing); the data terms are
divided by the number S of demonstration steps (see tric_learning.training.value).

With the config's end_flatness > 0 (an addition to the paper, off by default), the loss adds
end_flatness times L_e: the mean over the demonstrations of |grad_q f| squared at their last state,
over its mean square on L_g's steps (dimensionless, as L_g, so f's scale does not change it): f
flat where the demonstrations end, a stationary point the hold's ranking makes a minimum.
"""

import numpy as np
import scipy.optimize
import torch

from tric_learning.training import samples
from tric_learning.training.dataset import Dataset
from tric_learning.training.hyperparameters import TrainingConfig
from tric_learning.training.lbfgs import deterministic_torch, minimize_lbfgs
from tric_learning.value_function import Scaling


class TrainingProblem:
    """The loss of Eq. 11 as a torch function of the flattened weights."""

    def __init__(
        self,
        dataset: Dataset,
        noisy: samples.NoisySamples,
        scaling: Scaling,
        config: "TrainingConfig",
    ):
        self.config = config
        dtype = torch.float64 if config.float64 or config.optimizer != "lbfgs" else torch.float32
        self.bias = bool(config.hidden_bias and config.hidden_units)
        self.s, self.k = len(scaling.kept), config.hidden_units
        self.u = torch.tensor(
            scaling.transform(np.concatenate([d.y for d in dataset.demos])), dtype=dtype
        )
        self.steps = len(self.u)
        self.u_noisy = torch.tensor(scaling.transform(noisy.y), dtype=dtype)
        self.noisy_step = torch.tensor(noisy.step, dtype=torch.long)
        weight = noisy.weight
        if config.per_step_weights:
            sums = np.bincount(noisy.step, weights=noisy.weight, minlength=self.steps)
            weight = weight / np.maximum(sums[noisy.step], 1e-12)
        self.noisy_weight = torch.tensor(weight, dtype=dtype)
        # L_g: the steps with a direction, their (scaled) Jacobians du/dq and directions
        offsets = samples.step_offsets(dataset)
        directions: list | np.ndarray  # a list, then an array (G, n)
        rows, jacobians, directions = [], [], []
        for i, demo in enumerate(dataset.demos):
            delta = np.diff(demo.q, axis=0)
            lengths = np.linalg.norm(delta, axis=1)
            moving = np.flatnonzero((lengths >= config.lg_min_step) & (lengths > 0))
            rows.append(offsets[i] + moving)
            jacobians.append(
                demo.jacobians[moving][:, scaling.kept, :] * scaling.factor[None, :, None]
            )
            directions.append(delta[moving])
        self.g_rows = torch.tensor(np.concatenate(rows), dtype=torch.long)
        self.g_jacobian = torch.tensor(np.concatenate(jacobians), dtype=dtype)  # (G, s, n)
        directions = np.concatenate(directions)
        self.g_direction = torch.tensor(directions, dtype=dtype)  # (G, n)
        lengths = np.linalg.norm(directions, axis=1)
        weights = (
            lengths / lengths.mean() if config.lg_weighting == "length" else np.ones(len(lengths))
        )
        self.g_weight = torch.tensor(weights, dtype=dtype)  # (G,)
        # L_e: each demonstration's last state and its (scaled) Jacobian
        self.end_rows = torch.tensor(offsets[1:] - 1, dtype=torch.long)
        self.end_jacobian = torch.tensor(
            np.stack(
                [
                    demo.jacobians[-1][scaling.kept, :] * scaling.factor[:, None]
                    for demo in dataset.demos
                ]
            ),
            dtype=dtype,
        )  # (D, s, n)
        rng = np.random.default_rng(config.seed)
        initial = np.concatenate(
            [
                rng.normal(0.0, 1.0 / np.sqrt(max(self.s, 1)), self.k * self.s),
                rng.normal(0.0, 0.1, self.k),
                rng.normal(0.0, 0.01, self.s),
                np.zeros(self.k if self.bias else 0),
            ]
        )
        self.theta = torch.tensor(initial, dtype=dtype, requires_grad=True)

    def _split(self, theta):
        """(W1, W2, W3, b1) of the flattened weights; b1 zeros without hidden biases."""
        k, s = self.k, self.s
        w1, w2 = theta[: k * s].reshape(k, s), theta[k * s : k * s + k]
        w3 = theta[k * s + k : k * s + k + s]
        b1 = theta[k * s + k + s :] if self.bias else torch.zeros(k, dtype=theta.dtype)
        return w1, w2, w3, b1

    def terms(self, theta):
        """(L_n, L_g, |w|_1, L_e) as tensors; L_e zero (not computed) with end_flatness 0."""
        w1, w2, w3, b1 = self._split(theta)

        def value(u):
            out = u @ w3
            return out + torch.sigmoid(u @ w1.T + b1) @ w2 if self.k else out

        def gradient_q(rows, jacobian):
            u = self.u[rows]
            du = w3.expand(len(u), -1)
            if self.k:
                z = torch.sigmoid(u @ w1.T + b1)
                du = du + (z * (1 - z) * w2) @ w1
            return torch.einsum("gsn,gs->gn", jacobian, du)

        f_demo = value(self.u)
        f_noisy = value(self.u_noisy)
        loss_n = torch.sum(
            self.noisy_weight * torch.nn.functional.softplus(f_demo[self.noisy_step] - f_noisy)
        )
        along = gradient_q(self.g_rows, self.g_jacobian)
        loss_g = torch.sum(
            self.g_weight
            * torch.nn.functional.cosine_similarity(along, self.g_direction, dim=1, eps=1e-12)
        )
        loss_w = theta.abs().sum()
        loss_e = torch.zeros((), dtype=theta.dtype)
        if self.config.end_flatness > 0:
            end = gradient_q(self.end_rows, self.end_jacobian)
            loss_e = torch.mean(torch.sum(end**2, dim=1)) / (
                torch.mean(torch.sum(along**2, dim=1)) + 1e-12
            )
        return loss_n, loss_g, loss_w, loss_e

    def solve(self, report):
        """Minimize the loss; ((W1, W2, W3, b1), final loss terms, iterations)."""
        with deterministic_torch():
            if self.config.optimizer == "lbfgsb":
                iterations = self._solve_split(report)
            elif self.config.optimizer == "bfgs":
                iterations = self._solve_bfgs(report)
            else:
                iterations = self._solve_lbfgs(report)
        with torch.no_grad():
            losses = self._losses(*self.terms(self.theta))
        weights = tuple(
            t.detach().to(torch.float64).numpy().copy() for t in self._split(self.theta)
        )
        return weights, losses, int(iterations)

    def _data_loss(self, theta):
        """(alpha_n L_n + alpha_g L_g) / S + end_flatness L_e and the terms (L_n, L_g, |w|_1,
        L_e) as tensors."""
        loss_n, loss_g, loss_w, loss_e = terms = self.terms(theta)
        config = self.config
        data = (config.alpha_n * loss_n + config.alpha_g * loss_g) / self.steps
        if config.end_flatness > 0:
            data = data + config.end_flatness * loss_e
        return data, terms

    def _losses(self, loss_n, loss_g, loss_w, loss_e) -> dict:
        """The terms as the model file records them: L_n and L_g per step, |w|_1, L_e (only with
        end_flatness > 0) and the total."""
        config = self.config
        losses = dict(n=float(loss_n) / self.steps, g=float(loss_g) / self.steps, w=float(loss_w))
        losses["total"] = (
            config.alpha_n * losses["n"]
            + config.alpha_g * losses["g"]
            + config.alpha_w * losses["w"]
        )
        if config.end_flatness > 0:
            losses["e"] = float(loss_e)
            losses["total"] += config.end_flatness * losses["e"]
        return losses

    def _report(self, report, iteration, *terms):
        latest = self._losses(*terms)
        report(
            "optimizing",
            min(iteration / self.config.max_iterations, 1.0),
            dict(latest, iteration=iteration),
        )

    def _solve_split(self, report) -> int:
        """SciPy's L-BFGS-B on x = (w+, w-) >= 0, w = w+ - w-: the data loss plus alpha_w sum(x)."""
        config = self.config
        start = self.theta.detach().numpy()
        x0 = np.concatenate([np.maximum(start, 0.0), np.maximum(-start, 0.0)])
        size = len(start)
        state = {"iteration": 0}

        def objective(x):
            theta = torch.tensor(x[:size] - x[size:], dtype=self.theta.dtype, requires_grad=True)
            data, terms = self._data_loss(theta)
            data.backward()
            gradient = theta.grad.numpy()
            state["terms"] = [float(t.detach()) for t in terms]
            value = float(data.detach()) + config.alpha_w * float(np.sum(x))
            return value, np.concatenate([gradient + config.alpha_w, -gradient + config.alpha_w])

        def iterated(_x):
            state["iteration"] += 1
            self._report(report, state["iteration"], *state["terms"])

        result = scipy.optimize.minimize(
            objective,
            x0,
            jac=True,
            method="L-BFGS-B",
            bounds=[(0.0, None)] * (2 * size),
            callback=iterated,
            options={"maxiter": config.max_iterations, "maxcor": 20, "ftol": 1e-12, "gtol": 1e-10},
        )
        with torch.no_grad():
            self.theta.copy_(
                torch.tensor(result.x[:size] - result.x[size:], dtype=self.theta.dtype)
            )
        return result.nit

    def _solve_bfgs(self, report) -> int:
        """SciPy's BFGS (a dense inverse-Hessian estimate, float64), as the paper's MATLAB BFGS, on
        the whole loss with |w|_1's subgradient sign(w)."""
        config = self.config
        state = {"iteration": 0}

        def objective(x):
            theta = torch.tensor(x, dtype=self.theta.dtype, requires_grad=True)
            data, terms = self._data_loss(theta)
            total = data + config.alpha_w * terms[2]
            total.backward()
            state["terms"] = [float(t.detach()) for t in terms]
            return float(total.detach()), theta.grad.numpy().copy()

        def iterated(_x):
            state["iteration"] += 1
            self._report(report, state["iteration"], *state["terms"])

        result = scipy.optimize.minimize(
            objective,
            self.theta.detach().numpy().copy(),
            jac=True,
            method="BFGS",
            callback=iterated,
            options={"maxiter": config.max_iterations, "gtol": 1e-10},
        )
        with torch.no_grad():
            self.theta.copy_(torch.tensor(result.x, dtype=self.theta.dtype))
        return result.nit

    def _solve_lbfgs(self, report) -> int:
        config = self.config

        def loss(iteration):
            data, terms = self._data_loss(self.theta)
            self._report(report, iteration, *(t.detach() for t in terms))
            return data + config.alpha_w * terms[2]

        torch.manual_seed(config.seed)
        return minimize_lbfgs(self.theta, loss, config.max_iterations, tolerance_change=1e-12)
