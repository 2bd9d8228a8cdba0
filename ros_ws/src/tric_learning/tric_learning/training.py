"""Training TRIC's value function (paper Sec. 3.2, Eq. 11-17) with L-BFGS.

    L(D; w) = 1/S sum_i sum_t (alpha_n L_n(y_t^i) + alpha_g L_g(q_t^i)) + alpha_w |w|_1    (11)
    L_n(y_t) = sum_m eps_{t,m} log(1 + exp(f(y_t) - f(y~_{t,m})))                         (16)
    L_g(q_t) = cos(grad_q (f o phi)(q_t), q_{t+1} - q_t)                                    (17)

with grad_q (f o phi) = (df/dy)(dphi/dq) from the recorded Jacobians (Eq. 10). Steps where the
demonstration does not move (|q_{t+1} - q_t| < MIN_STEP) have no direction and are left out of L_g.
The data terms are divided by the number S of demonstration steps (N T): then the paper's
alpha_w = 0.001 gives its regularization whatever N and T are (summed, it would grow weaker with
every demonstration added; measured here, the summed form leaves f too rough to control with).
The noisy samples are drawn once (tric_learning.samples); the optimizer is PyTorch's L-BFGS with a
strong-Wolfe line search on the full batch, in float32, with PyTorch's deterministic algorithms
(deterministic_torch): the same seed gives the same model on a given machine, run after run
(docs/decisions/seed-lottery.md). The defaults are the paper's but for the balance of the terms:
in this form of the loss the paper's alpha_g = 1 leaves L_g about ten times weaker than L_n, so
alpha_g = 30 with 300 iterations (the paper: 100 of BFGS), chosen on the training and validation
sets over three seeds (docs/decisions/loss-balance.md).

train_from_bags() is the whole job that the trainer node and tric-train share: bags -> dataset ->
train() -> model file.
"""

import contextlib
import pathlib
import time
from dataclasses import asdict, dataclass

import numpy as np
import scipy.optimize
import torch

from tric_learning import model_file, samples
from tric_learning.dataset import Dataset
from tric_learning.recording import bag_paths, load_dataset
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.output_files import check_output_file
from tric_sim.robot_model import RobotModel

#: A demonstration step (between two samples) shorter than this has no direction for L_g: the hand
#: only settles, rad.
MIN_STEP = 0.03
#: Features whose score is above this fraction of the largest count as selected (Sec. 5.5.1).
SELECTED_FRACTION = 0.01
#: The controller's delta makes about this many control ticks from a demo's start value to its end
#: value (Sec. 5.2.3).
TICKS_PER_DEMO = 500
#: The controller's rho makes rho |grad_q (f o phi)|^2 this large at the demonstrations' median
#: gradient: the value term dominates the step-size term there (Proposition 1), and steps shrink
#: smoothly where the gradient vanishes.
RHO_GAIN = 100.0
#: The optimizers TrainingConfig.optimizer names.
OPTIMIZERS = ("lbfgs", "lbfgsb")
#: The model file written next to the first bag when no output path is given.
DEFAULT_MODEL_NAME = "model.safetensors"
MODEL_SUFFIX = ".safetensors"


@dataclass
class TrainingConfig:
    """Hyper-parameters: the paper's defaults but alpha_g and max_iterations (see the module
    docstring).

    hidden_units: K sigmoid units of f (0: the linear model), a count.
    noisy_samples: M noisy joint samples per demonstration step (Eq. 12-16), a count.
    sigma: the noisy samples' standard deviation around q_{t-1}, rad.
    alpha_n, alpha_g, alpha_w: the weights of L_n, L_g and |w|_1 in Eq. 11 (dimensionless).
    max_iterations: L-BFGS iterations at most.
    correlation_threshold: features correlated above this (|r| in (0, 1]) with a kept one are
        dropped.
    seed: draws the noisy samples and the initial weights.
    """

    hidden_units: int = 30
    noisy_samples: int = 60
    sigma: float = 0.05
    alpha_n: float = 1.0
    alpha_g: float = 30.0
    alpha_w: float = 0.001
    max_iterations: int = 300
    correlation_threshold: float = 0.995
    seed: int = 0
    #: L_n's weights eps divided by their sum at each step (each step's L_n a weighted mean over its
    #: noisy samples) instead of summed as in Eq. 16.
    per_step_weights: bool = False
    #: "lbfgs": PyTorch's L-BFGS on the whole loss, |w|_1 included (not smooth at 0); "lbfgsb":
    #: SciPy's L-BFGS-B on w = w+ - w-, w+, w- >= 0, where |w|_1 = sum(w+ + w-) is linear (exact L1,
    #: sparse).
    optimizer: str = "lbfgs"

    def validate(self) -> "TrainingConfig":
        """Return self, or ValueError naming the first value out of range."""
        checks = [
            (0 <= self.hidden_units <= 1000, "hidden_units must be in [0, 1000]"),
            (1 <= self.noisy_samples <= 10000, "noisy_samples must be in [1, 10000]"),
            (0 < self.sigma <= 1.0, "sigma must be in (0, 1] rad"),
            (
                all(a >= 0 and np.isfinite(a) for a in (self.alpha_n, self.alpha_g, self.alpha_w)),
                "alpha_n, alpha_g and alpha_w must be finite and >= 0",
            ),
            (self.alpha_n + self.alpha_g > 0, "alpha_n and alpha_g cannot both be 0"),
            (1 <= self.max_iterations <= 100000, "max_iterations must be in [1, 100000]"),
            (0 < self.correlation_threshold <= 1, "correlation_threshold must be in (0, 1]"),
            (0 <= self.seed < 2**32, "seed must be in [0, 2^32)"),
            (self.optimizer in OPTIMIZERS, f"optimizer must be one of {', '.join(OPTIMIZERS)}"),
        ]
        for ok, message in checks:
            if not ok:
                raise ValueError(message)
        return self

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class TrainingResult:
    """A trained model with its record: loss terms (L_n and L_g per demonstration step, |w|_1),
    times (s), the controller's delta and rho, counts."""

    model: ValueFunction
    config: TrainingConfig
    losses: dict
    iterations: int
    sampling_time_s: float
    optimization_time_s: float
    delta: float
    rho: float
    selected_features: int
    mean_samples_per_step: float

    @property
    def train_time_s(self) -> float:
        return self.sampling_time_s + self.optimization_time_s


def train(
    dataset: Dataset,
    robot: RobotModel,
    config: TrainingConfig | None = None,
    progress=None,
    extra_samples: samples.NoisySamples = None,
) -> TrainingResult:
    """Train f on dataset. progress(stage, fraction, losses) is called during sampling and after
    each optimizer evaluation (losses: dict of the current terms, or None). extra_samples: more
    contrasts for L_n beside the noisy ones (e.g. states a learned controller visited: hard
    negatives), each with the demonstration step it is contrasted with and its weight."""
    config = TrainingConfig() if config is None else config
    config.validate()
    dataset.check()
    report = progress or (lambda *_: None)
    start = time.perf_counter()
    noisy = samples.generate(
        dataset,
        robot,
        config.noisy_samples,
        config.sigma,
        config.seed,
        lambda done, total: report("sampling", done / total, None),
    )
    if extra_samples is not None:
        noisy = samples.joined(noisy, extra_samples)
    sampling_time = time.perf_counter() - start
    start = time.perf_counter()
    # the scaling spans everything the model is trained on: the demonstrations and the noisy samples
    all_y = np.concatenate([demo.y for demo in dataset.demos] + [noisy.y])
    scaling = Scaling.fit(all_y, config.correlation_threshold)
    problem = _Problem(dataset, noisy, scaling, config)
    weights, losses, iterations = problem.solve(report)
    model = ValueFunction(scaling, *weights)
    optimization_time = time.perf_counter() - start
    starts = np.array([model.value(demo.y[0]) for demo in dataset.demos])
    ends = np.array([model.value(demo.y[-1]) for demo in dataset.demos])
    norms = [
        np.linalg.norm(model.gradient(y)[1] @ jacobian)
        for demo in dataset.demos
        for y, jacobian in zip(demo.y, demo.jacobians)
    ]
    scores = model.scores()
    return TrainingResult(
        model=model,
        config=config,
        losses=losses,
        iterations=iterations,
        sampling_time_s=sampling_time,
        optimization_time_s=optimization_time,
        delta=float(np.mean(starts - ends) / TICKS_PER_DEMO),
        rho=float(RHO_GAIN / max(np.median(norms), 1e-9) ** 2),
        selected_features=int(np.sum(scores > SELECTED_FRACTION * scores.max()))
        if scores.max() > 0
        else 0,
        mean_samples_per_step=float(noisy.kept_per_step[_later_steps(dataset)].mean()),
    )


@dataclass
class BagTraining:
    """What train_from_bags() did: the model file written, the dataset and the training result."""

    path: pathlib.Path
    dataset: Dataset
    result: TrainingResult


def model_output_path(output_path, first_bag: pathlib.Path) -> pathlib.Path:
    """Where the model goes: output_path, or DEFAULT_MODEL_NAME next to first_bag when output_path
    is empty; ValueError if it is not a writable .safetensors file path."""
    path = pathlib.Path(output_path) if output_path else first_bag.parent / DEFAULT_MODEL_NAME
    return check_output_file(path, (MODEL_SUFFIX,), "the model path")


def train_from_bags(
    paths,
    output_path,
    config: TrainingConfig,
    robot: RobotModel,
    progress=None,
    *,
    include_failed: bool = False,
    tolerant: bool = False,
    notice=None,
) -> BagTraining:
    """Load the demonstrations in the bags at paths (files or folders, see recording.load_dataset
    for include_failed, tolerant and notice), train on them and write the model file to output_path
    (see model_output_path). Every input is checked before anything is written: a bad bag, value
    or path raises ValueError and leaves no file. progress(stage, fraction, losses) as in train(),
    with the stages "loading" and "saving" before and after it."""
    config.validate()
    files = bag_paths(paths, tolerant, notice)
    path = model_output_path(output_path, files[0])
    report = progress or (lambda *_: None)
    report("loading", 0.0, None)
    dataset = load_dataset(
        files,
        robot,
        lambda done, total: report("loading", done / total, None),
        include_failed=include_failed,
        tolerant=tolerant,
        notice=notice,
    )
    result = train(dataset, robot, config, report)
    report("saving", 0.0, result.losses)
    model_file.from_training(result, dataset).save(path)
    report("saving", 1.0, result.losses)
    return BagTraining(path, dataset, result)


def minimize_lbfgs(theta, loss, max_iterations: int, tolerance_change: float) -> int:
    """Minimize loss(iteration), a scalar tensor of the parameters theta (1-D, requires grad), in
    place by L-BFGS with a strong-Wolfe line search (history 20, at most max_iterations iterations
    and twice as many evaluations; stops when the gradient's largest entry is below 1e-10 or the
    loss changes by less than tolerance_change). loss gets the iterations done so far, for
    progress reports. Returns the iterations done."""
    optimizer = torch.optim.LBFGS(
        [theta],
        lr=1.0,
        max_iter=max_iterations,
        max_eval=max_iterations * 2,
        history_size=20,
        tolerance_grad=1e-10,
        tolerance_change=tolerance_change,
        line_search_fn="strong_wolfe",
    )

    def closure():
        optimizer.zero_grad()
        total = loss(optimizer.state[theta].get("n_iter", 0))
        total.backward()
        return total

    optimizer.step(closure)
    return optimizer.state[theta].get("n_iter", 0)


@contextlib.contextmanager
def deterministic_torch():
    """Within the block PyTorch uses only its deterministic algorithms (no run-to-run differences of
    its multi-threaded accumulations); the previous setting is restored after it."""
    previous = torch.are_deterministic_algorithms_enabled()
    torch.use_deterministic_algorithms(True)
    try:
        yield
    finally:
        torch.use_deterministic_algorithms(previous)


def _later_steps(dataset: Dataset) -> np.ndarray:
    """Flattened indices of every step t >= 1 (the ones with noisy samples)."""
    offsets = samples.step_offsets(dataset)
    return np.concatenate(
        [np.arange(offsets[i] + 1, offsets[i + 1]) for i in range(len(dataset.demos))]
    )


class _Problem:
    """The loss of Eq. 11 as a torch function of the flattened weights."""

    def __init__(
        self,
        dataset: Dataset,
        noisy: samples.NoisySamples,
        scaling: Scaling,
        config: TrainingConfig,
    ):
        self.config = config
        dtype = torch.float64 if config.optimizer == "lbfgsb" else torch.float32
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
        rows, jacobians, directions = [], [], []
        for i, demo in enumerate(dataset.demos):
            delta = np.diff(demo.q, axis=0)
            moving = np.flatnonzero(np.linalg.norm(delta, axis=1) >= MIN_STEP)
            rows.append(offsets[i] + moving)
            jacobians.append(
                demo.jacobians[moving][:, scaling.kept, :] * scaling.factor[None, :, None]
            )
            directions.append(delta[moving])
        self.g_rows = torch.tensor(np.concatenate(rows), dtype=torch.long)
        self.g_jacobian = torch.tensor(np.concatenate(jacobians), dtype=dtype)  # (G, s, n)
        self.g_direction = torch.tensor(np.concatenate(directions), dtype=dtype)  # (G, n)
        rng = np.random.default_rng(config.seed)
        initial = np.concatenate(
            [
                rng.normal(0.0, 1.0 / np.sqrt(max(self.s, 1)), self.k * self.s),
                rng.normal(0.0, 0.1, self.k),
                rng.normal(0.0, 0.01, self.s),
            ]
        )
        self.theta = torch.tensor(initial, dtype=dtype, requires_grad=True)

    def _split(self, theta):
        k, s = self.k, self.s
        return theta[: k * s].reshape(k, s), theta[k * s : k * s + k], theta[k * s + k :]

    def terms(self, theta):
        w1, w2, w3 = self._split(theta)

        def value(u):
            out = u @ w3
            return out + torch.sigmoid(u @ w1.T) @ w2 if self.k else out

        f_demo = value(self.u)
        f_noisy = value(self.u_noisy)
        loss_n = torch.sum(
            self.noisy_weight * torch.nn.functional.softplus(f_demo[self.noisy_step] - f_noisy)
        )
        u = self.u[self.g_rows]
        du = w3.expand(len(u), -1)
        if self.k:
            z = torch.sigmoid(u @ w1.T)
            du = du + (z * (1 - z) * w2) @ w1
        gradient_q = torch.einsum("gsn,gs->gn", self.g_jacobian, du)
        loss_g = torch.sum(
            torch.nn.functional.cosine_similarity(gradient_q, self.g_direction, dim=1, eps=1e-12)
        )
        loss_w = theta.abs().sum()
        return loss_n, loss_g, loss_w

    def solve(self, report):
        """Minimize the loss; ((W1, W2, W3), final loss terms, iterations)."""
        with deterministic_torch():
            if self.config.optimizer == "lbfgsb":
                iterations = self._solve_split(report)
            else:
                iterations = self._solve_lbfgs(report)
        with torch.no_grad():
            loss_n, loss_g, loss_w = self.terms(self.theta)
        config = self.config
        losses = {
            "n": float(loss_n) / self.steps,
            "g": float(loss_g) / self.steps,
            "w": float(loss_w),
        }
        losses["total"] = (
            config.alpha_n * losses["n"]
            + config.alpha_g * losses["g"]
            + config.alpha_w * losses["w"]
        )
        w1, w2, w3 = (t.detach().to(torch.float64).numpy().copy() for t in self._split(self.theta))
        return (w1, w2, w3), losses, int(iterations)

    def _data_loss(self, theta):
        """(alpha_n L_n + alpha_g L_g) / S and the terms (L_n, L_g, |w|_1) as tensors."""
        loss_n, loss_g, loss_w = self.terms(theta)
        return (self.config.alpha_n * loss_n + self.config.alpha_g * loss_g) / self.steps, (
            loss_n,
            loss_g,
            loss_w,
        )

    def _report(self, report, iteration, loss_n, loss_g, loss_w):
        config = self.config
        latest = dict(n=float(loss_n) / self.steps, g=float(loss_g) / self.steps, w=float(loss_w))
        latest["total"] = (
            config.alpha_n * latest["n"]
            + config.alpha_g * latest["g"]
            + config.alpha_w * latest["w"]
        )
        report(
            "optimizing",
            min(iteration / config.max_iterations, 1.0),
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

    def _solve_lbfgs(self, report) -> int:
        config = self.config

        def loss(iteration):
            data, terms = self._data_loss(self.theta)
            self._report(report, iteration, *(t.detach() for t in terms))
            return data + config.alpha_w * terms[2]

        torch.manual_seed(config.seed)
        return minimize_lbfgs(self.theta, loss, config.max_iterations, tolerance_change=1e-12)
