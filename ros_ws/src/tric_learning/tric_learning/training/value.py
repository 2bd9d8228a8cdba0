"""Training TRIC's value function (paper Sec. 3.2, Eq. 11-17) with L-BFGS.

    L(D; w) = 1/S sum_i sum_t (alpha_n L_n(y_t^i) + alpha_g L_g(q_t^i)) + alpha_w |w|_1    (11)
    L_n(y_t) = sum_m eps_{t,m} log(1 + exp(f(y_t) - f(y~_{t,m})))                         (16)
    L_g(q_t) = cos(grad_q (f o phi)(q_t), q_{t+1} - q_t)                                    (17)

with grad_q (f o phi) = (df/dy)(dphi/dq) from the recorded Jacobians (Eq. 10). L_g sums over every
demonstration step, each weighted by its length |q_{t+1} - q_t| over the mean length (the paper
weighs every step alike; docs/decisions/paper-fidelity.md measured the departure: the steps where
the hand only settles have directions of no consequence, and counting them alike made the grasps
and the boxes worse). The data terms are divided by the number S of demonstration steps, so
alpha_w = 0.001 weighs |w|_1 about S times more than the paper's summed loss does (measured: the
paper's weaker L1 leaves f too rough, docs/decisions/loss-balance.md; weaker still or stronger,
the validation tasks get worse, docs/decisions/paper-fidelity.md). The noisy samples
(tric_learning.training.samples) are drawn once, with the objects where they were at t - 1; the
optimizer is PyTorch's L-BFGS with a strong-Wolfe line search on the full batch, in float32, with
PyTorch's deterministic algorithms (lbfgs.deterministic_torch): the same seed gives the same model
on a given machine, run after run (docs/decisions/seed-lottery.md). The defaults are the paper's but
for the balance of the terms and the iterations: the paper's alpha_g = 1 leaves L_g about ten times
weaker than L_n in this loss (its L_n sums eps over M = 60 samples of about 0.2 rad each), so
alpha_g = 30 with 300 iterations (the paper: 100 of BFGS), chosen on the training and validation
sets over three seeds (docs/decisions/loss-balance.md, re-chosen with the samples and L_g of today
in docs/decisions/paper-fidelity.md).

The loss and its optimizer are tric_learning.training.problem's; train_from_bags() is the whole job
that the trainer node and tric-train share: bags -> dataset -> train() -> model file
(tric_learning.training.from_bags).
"""

import time
import warnings
from dataclasses import dataclass

import numpy as np

from tric_learning import model_file
from tric_learning.training import samples
from tric_learning.training.dataset import Dataset
from tric_learning.training.from_bags import BagTraining, train_on_bags
from tric_learning.training.hyperparameters import TrainingConfig
from tric_learning.training.problem import TrainingProblem
from tric_learning.training.rest import rest_info
from tric_learning.value_function import Scaling, ValueFunction
from tric_sim.world.robot_model import RobotModel

#: Features whose score is above this fraction of the largest count as selected (Sec. 5.5.1).
SELECTED_FRACTION = 0.01
#: The controller's delta makes about this many control ticks from a demo's start value to its end
#: value (Sec. 5.2.3).
TICKS_PER_DEMO = 500
#: The controller's rho makes rho |grad_q (f o phi)|^2 this large at the demonstrations' median
#: gradient: the value term dominates the step-size term there (Proposition 1), and steps shrink
#: smoothly where the gradient vanishes.
RHO_GAIN = 100.0


@dataclass
class TrainingResult:
    """A trained model with its record: loss terms (L_n and L_g per demonstration step, |w|_1),
    times (s), the controller's delta and rho, counts, its rest rule (training.rest.RestRule's
    dict; None where the demonstrations are too short to give one) and the identity of the robot
    profile it was trained on (RobotProfile.identity)."""

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
    rest: dict | None
    robot_profile: str

    @property
    def train_time_s(self) -> float:
        return self.sampling_time_s + self.optimization_time_s


def train(
    dataset: Dataset,
    robot: RobotModel,
    config: TrainingConfig | None = None,
    progress=None,
    extra_samples: samples.NoisySamples | None = None,
) -> TrainingResult:
    """Train f on dataset. progress(stage, fraction, losses) is called during sampling and after
    each optimizer evaluation (losses: dict of the current terms, or None). extra_samples: more
    contrasts for L_n beside the noisy ones (e.g. states a learned controller visited: hard
    negatives), each with the demonstration step it is contrasted with and its weight. The
    scaling spans everything the model is trained on: the demonstrations and the noisy samples."""
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
        contact_tolerance=config.sample_contact_tolerance,
        scene_step=config.sample_scene_step,
        hold=config.hold_samples,
    )
    if extra_samples is not None:
        noisy = samples.joined(noisy, extra_samples)
    sampling_time = time.perf_counter() - start
    start = time.perf_counter()
    all_y = np.concatenate([demo.y for demo in dataset.demos] + [noisy.y])
    scaling = Scaling.fit(all_y, config.correlation_threshold)
    weights, losses, iterations = TrainingProblem(dataset, noisy, scaling, config).solve(report)
    model = ValueFunction(scaling, *weights)
    optimization_time = time.perf_counter() - start
    kept_per_step = noisy.kept_per_step
    delta, rho = controller_gains(model, dataset)
    return TrainingResult(
        model=model,
        config=config,
        losses=losses,
        iterations=iterations,
        sampling_time_s=sampling_time,
        optimization_time_s=optimization_time,
        delta=delta,
        rho=rho,
        selected_features=selected_count(model),
        mean_samples_per_step=float(kept_per_step[_later_steps(dataset)].mean()),
        rest=rest_info(model, dataset),
        robot_profile=robot.profile.identity,
    )


def controller_gains(model: ValueFunction, dataset: Dataset) -> tuple:
    """(delta, rho) of the controller for model: delta the demonstrations' mean fall of f over
    TICKS_PER_DEMO (Sec. 5.2.3), rho RHO_GAIN over the squared median of |grad_q (f o phi)| along
    them."""
    starts = np.array([model.value(demo.y[0]) for demo in dataset.demos])
    ends = np.array([model.value(demo.y[-1]) for demo in dataset.demos])
    norms = [
        np.linalg.norm(model.gradient(y)[1] @ jacobian)
        for demo in dataset.demos
        for y, jacobian in zip(demo.y, demo.jacobians)
    ]
    return (
        float(np.mean(starts - ends) / TICKS_PER_DEMO),
        float(RHO_GAIN / max(np.median(norms), 1e-9) ** 2),
    )


def selected_count(model: ValueFunction) -> int:
    """How many features carry weight: a score s(y) above SELECTED_FRACTION of the largest."""
    scores = model.scores()
    return int(np.sum(scores > SELECTED_FRACTION * scores.max())) if scores.max() > 0 else 0


def mean_of_members(functions: list, dataset: Dataset) -> ValueFunction:
    """The mean of f_k / fall_k over the members (value functions on one Scaling) whose f falls
    along the demonstrations (fall_k: the mean of f_k(start) - f_k(end) over the demos), so that
    the ensemble falls by 1 on average: the ensembles of a model's selection
    (tric_control.selection.choice). A member whose f does not fall is left out with a
    RuntimeWarning naming it, and ValueError if none falls."""
    falls = np.array(
        [
            np.mean([f.value(demo.y[0]) - f.value(demo.y[-1]) for demo in dataset.demos])
            for f in functions
        ]
    )
    falling = np.flatnonzero(falls > 0)
    if not falling.size:
        raise ValueError("no member of the ensemble learned an f that falls along the demos")
    for k in np.flatnonzero(falls <= 0):
        warnings.warn(
            f"ensemble member {k} left out: its f does not fall along the demos "
            f"(mean fall {falls[k]:.4g})",
            RuntimeWarning,
            stacklevel=2,
        )
    return ValueFunction.ensemble(
        [functions[k] for k in falling], 1.0 / (len(falling) * falls[falling])
    )


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
    overwrite: bool = True,
) -> BagTraining:
    """Load the demonstrations in the bags at paths (files or folders, see bag_dataset.load_dataset
    for include_failed, tolerant and notice), train on them and write the model file to output_path
    (from_bags.train_on_bags: the path claimed, its room checked before the training, a file that
    appeared there meanwhile replaced only if overwrite). Every input is checked before anything is
    written: a bad bag, value or path raises ValueError and leaves no file. progress(stage,
    fraction, losses) as in train(), with the stages "loading" and "saving" before and after it."""
    config.validate()
    return train_on_bags(
        paths,
        output_path,
        robot,
        progress,
        lambda dataset, report: train(dataset, robot, config, report),
        model_file.from_training,
        include_failed=include_failed,
        tolerant=tolerant,
        notice=notice,
        hidden_units=config.hidden_units,
        overwrite=overwrite,
    )


def _later_steps(dataset: Dataset) -> np.ndarray:
    """Flattened indices of every step t >= 1 (the ones with noisy samples)."""
    offsets = samples.step_offsets(dataset)
    return np.concatenate(
        [np.arange(offsets[i] + 1, offsets[i + 1]) for i in range(len(dataset.demos))]
    )
