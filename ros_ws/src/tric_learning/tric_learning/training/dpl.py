"""The DPL baseline (direct policy learning, paper Sec. 2 Eq. 2 and Sec. 5.3.2). ROS-free.

A network with K sigmoid units regresses the demonstrated step from a state x (each input rescaled
as TRIC's, value_function.Scaling):

    pi(y) = W2 z + b2,    z = sigmoid(W1 u + b1),    u = Scaling(y)

with W1 (K, s), b1 (K,), W2 (m, K), b2 (m,). Two kinds, with their states and targets, one per
demonstration step t:
- "dpl_joint": x = y, the task features (the feature map and bags TRIC trains on: the paper's
  state for the spheres, Sec. 5.3.2); the joint step u_t = q_{t+1} - q_t (m = n joints, rad);
- "dpl_finger" (box opening, Sec. 5.3.5): the finger space, the fingertip landmarks' positions in
  the box frame (the features p[box->fingertip_k].xyz), as the state and as the control: the step
  y_{t+1} - y_t on those features (m = 3 per fingertip, metres). With every feature as its state
  it opened 0 to 1 of 25 validation boxes, with its finger space 11 to 13
  (docs/decisions/dpl-settings.md).

Training minimizes the least-squares loss of Eq. 2 plus a small L2 penalty on W1 and W2, with
PyTorch's L-BFGS (strong-Wolfe line search, full batch, float64), deterministic for a given seed,
on one thread: the problem is small (about 1000 steps x 60 units), and two threads were slower
(docs/decisions/dpl-settings.md).
For conditioning the network is fitted to the targets divided by their RMS (one number for all
outputs, so the loss stays Eq. 2's, only rescaled); W2 and b2 are multiplied back afterwards, so
the saved network predicts in rad or m. A step is per sample period of the demonstrations (the
paper's 125 ms), which the model file records as sample_period_s.

train_dpl_from_bags() is the whole job for tric-train --kind and the trainer node: bags -> dataset
-> train_dpl() -> model file, by tric_learning.training.from_bags as TRIC's training.
"""

import time
from dataclasses import dataclass

import numpy as np
import torch

from tric_learning.features import FeatureDefinition
from tric_learning.model_file import ModelFile
from tric_learning.training.dataset import Dataset
from tric_learning.training.from_bags import BagTraining, train_on_bags
from tric_learning.training.hyperparameters import DPL_KINDS, DplConfig
from tric_learning.training.lbfgs import deterministic_torch, minimize_lbfgs
from tric_learning.value_function import Scaling, sigmoid
from tric_sim.tools.provenance import code_digest
from tric_sim.world.robot_model import RobotModel

#: dpl_finger: the landmark whose frame the fingertips are expressed in, and the fingertips' prefix.
FINGER_FRAME = "box"
FINGERTIP_PREFIX = "fingertip"


@dataclass
class DplPolicy:
    """pi(y) of the module docstring on raw features through its Scaling."""

    scaling: Scaling
    w1: np.ndarray
    b1: np.ndarray
    w2: np.ndarray
    b2: np.ndarray

    def predict(self, y: np.ndarray) -> np.ndarray:
        """The predicted step (..., m) per sample period at raw features y (..., d)."""
        u = self.scaling.transform(y)
        return sigmoid(u @ self.w1.T + self.b1) @ self.w2.T + self.b2


@dataclass
class DplResult:
    """A trained policy with its record: losses ("mse": the training mean squared error per output,
    rad^2 or m^2; "mean_abs_error": likewise |.|; "total": the minimized objective; "l2": |W1|^2 +
    |W2|^2 of the normalized network), the RMS of the targets, the sample period (s), times (s), the
    identity of the robot profile it was trained on (RobotProfile.identity)."""

    policy: DplPolicy
    kind: str
    config: DplConfig
    losses: dict
    iterations: int
    target_rms: float
    sample_period_s: float
    optimization_time_s: float
    robot_profile: str

    @property
    def train_time_s(self) -> float:
        return self.optimization_time_s


def finger_rows(definition: FeatureDefinition) -> np.ndarray:
    """Indices into y (3 F,) of p[box->fingertip_k].xyz, the fingertips' positions in the box frame;
    ValueError if the definition has no box or no fingertip landmark."""
    names = list(definition.landmark_names)
    fingertips = [k for k, name in enumerate(names) if name.startswith(FINGERTIP_PREFIX)]
    if FINGER_FRAME not in names or not fingertips:
        raise ValueError(
            f"dpl_finger needs the '{FINGER_FRAME}' landmark and {FINGERTIP_PREFIX}* landmarks "
            f"(the open_box task); the feature definition of task '{definition.task}' has "
            f"{', '.join(names)}"
        )
    frame = names.index(FINGER_FRAME)
    pairs = [definition.pairs.index((frame, k)) for k in fingertips]
    return np.array([4 * p + axis for p in pairs for axis in range(3)], dtype=np.int64)


def target_names(definition: FeatureDefinition, kind: str) -> list:
    """What each output of a kind's policy is: joint names or feature names."""
    if kind == "dpl_joint":
        return list(definition.joint_names)
    check_kind(kind)
    return [definition.feature_names[k] for k in finger_rows(definition)]


def check_kind(kind: str) -> None:
    """ValueError unless kind is a DPL kind."""
    if kind not in DPL_KINDS:
        raise ValueError(f"unknown DPL kind '{kind}' (known: {', '.join(DPL_KINDS)})")


def training_pairs(dataset: Dataset, kind: str):
    """(inputs y_t (S, d), targets (S, m)) over every demonstration step t < T - 1 (see the module
    docstring for the targets of each kind)."""
    inputs, targets = [], []
    rows = finger_rows(dataset.definition) if kind == "dpl_finger" else None
    for demo in dataset.demos:
        inputs.append(demo.y[:-1])
        targets.append(
            np.diff(demo.q, axis=0) if rows is None else np.diff(demo.y[:, rows], axis=0)
        )
    return np.concatenate(inputs), np.concatenate(targets)


def input_scaling(y: np.ndarray, correlation_threshold: float, rows=None) -> Scaling:
    """The policy's input scaling fitted on features y (S, d): every feature (rows None, TRIC's
    scaling), or only the features rows (dpl_finger's state: its own finger space)."""
    if rows is None:
        return Scaling.fit(y, correlation_threshold)
    rows = np.asarray(rows)
    subset = Scaling.fit(y[:, rows], correlation_threshold)
    return Scaling(rows[subset.kept], subset.low, subset.high, y.shape[1])


def sample_period(dataset: Dataset) -> float:
    """The demonstrations' mean sample period, s (samples fall on control ticks, so single periods
    jitter by a tick around it)."""
    duration = sum(int(demo.stamps_ns[-1] - demo.stamps_ns[0]) for demo in dataset.demos)
    return duration * 1e-9 / sum(demo.length - 1 for demo in dataset.demos)


def train_dpl(
    dataset: Dataset,
    robot: RobotModel,
    config: DplConfig | None = None,
    kind: str = "dpl_joint",
    progress=None,
) -> DplResult:
    """Train a DPL policy of kind on dataset, whose feature definition must be robot's for its
    task (the recorded features are used). progress(stage, fraction, losses) after each optimizer
    evaluation, with stage "optimizing" and losses the current terms with the iteration."""
    config = DplConfig() if config is None else config
    config.validate()
    dataset.check()
    check_kind(kind)
    FeatureDefinition.for_task(dataset.definition.task, robot).check_same(
        dataset.definition, "the dataset"
    )
    inputs, targets = training_pairs(dataset, kind)
    start = time.perf_counter()
    scaling = input_scaling(
        np.concatenate([demo.y for demo in dataset.demos]),
        config.correlation_threshold,
        finger_rows(dataset.definition) if kind == "dpl_finger" else None,
    )
    target_rms = float(np.sqrt(np.mean(targets**2)))
    if not target_rms > 0:
        raise ValueError("the demonstrations do not move: every DPL target is zero")
    problem = _Regression(scaling.transform(inputs), targets / target_rms, config)
    with deterministic_torch():
        (w1, b1, w2, b2), losses, iterations = problem.solve(progress or (lambda *_: None))
    policy = DplPolicy(scaling, w1, b1, w2 * target_rms, b2 * target_rms)
    errors = policy.predict(inputs) - targets
    losses.update(mse=float(np.mean(errors**2)), mean_abs_error=float(np.mean(np.abs(errors))))
    return DplResult(
        policy=policy,
        kind=kind,
        config=config,
        losses=losses,
        iterations=iterations,
        target_rms=target_rms,
        sample_period_s=sample_period(dataset),
        optimization_time_s=time.perf_counter() - start,
        robot_profile=robot.profile.identity,
    )


def train_dpl_from_bags(
    paths,
    output_path,
    config: DplConfig,
    robot: RobotModel,
    progress=None,
    *,
    kind: str,
    include_failed: bool = False,
    tolerant: bool = False,
    notice=None,
    overwrite: bool = True,
) -> BagTraining:
    """As training.train_from_bags (the same arguments, then the kind), for a DPL kind: every input
    is checked before anything is written (a bad bag, value, kind or path raises ValueError and
    leaves no file). progress(stage, fraction, losses) with the stages "loading", "optimizing" and
    "saving"."""
    config.validate()
    check_kind(kind)
    return train_on_bags(
        paths,
        output_path,
        robot,
        progress,
        lambda dataset, report: train_dpl(dataset, robot, config, kind, report),
        to_model_file,
        include_failed=include_failed,
        tolerant=tolerant,
        notice=notice,
        hidden_units=config.hidden_units,
        overwrite=overwrite,
    )


def policy_arrays(policy: DplPolicy) -> dict:
    """The arrays of a DPL policy for a ModelFile."""
    return {
        "w1": policy.w1,
        "b1": policy.b1,
        "w2": policy.w2,
        "b2": policy.b2,
        "kept": policy.scaling.kept.astype(np.int64),
        "low": policy.scaling.low,
        "high": policy.scaling.high,
    }


def to_model_file(result: DplResult, dataset: Dataset) -> ModelFile:
    """The ModelFile of a DPL training result on dataset."""
    names = np.array(dataset.definition.feature_names)[result.policy.scaling.kept]
    return ModelFile(
        result.kind,
        dataset.definition,
        policy_arrays(result.policy),
        {
            "hyperparameters": result.config.to_dict(),
            "dataset_fingerprint": dataset.fingerprint,
            "training_code": code_digest(__name__),
            "demos": [demo.name for demo in dataset.demos],
            "losses": result.losses,
            "iterations": result.iterations,
            "optimization_time_s": result.optimization_time_s,
            "train_time_s": result.train_time_s,
            "robot_profile": result.robot_profile,
            "target_rms": result.target_rms,
            "sample_period_s": result.sample_period_s,
            "targets": target_names(dataset.definition, result.kind),
            "kept_features": names.tolist(),
        },
    )


def load_policy(model: ModelFile) -> DplPolicy:
    """The DPL policy of a ModelFile, or ValueError if it is not a DPL model or its arrays are
    missing, inconsistent with its kind and feature definition, or not finite."""
    if model.kind not in DPL_KINDS:
        raise ValueError(f"the model is a '{model.kind}' model, not a DPL policy")
    outputs = len(target_names(model.definition, model.kind))
    a = model.arrays
    try:
        kept, size = a["kept"].astype(int), model.definition.size
        w1, b1, w2, b2, low, high = (a[name] for name in ("w1", "b1", "w2", "b2", "low", "high"))
    except KeyError as missing:
        raise ValueError(f"the {model.kind} model file lacks the array {missing}") from None
    s = len(kept)
    if not (
        w1.ndim == 2
        and w1.shape[1] == s
        and b1.shape == (w1.shape[0],)
        and low.shape == (s,)
        and high.shape == (s,)
        and np.all((kept >= 0) & (kept < size))
        and np.all(high > low)
    ):
        raise ValueError(f"the {model.kind} model file's input arrays have inconsistent shapes")
    if w2.shape != (outputs, w1.shape[0]) or b2.shape != (outputs,):
        raise ValueError(
            f"the {model.kind} model file's output arrays have shapes {w2.shape} and {b2.shape}; "
            f"its feature definition needs {outputs} outputs"
        )
    for name in ("w1", "b1", "w2", "b2", "low", "high"):
        if not np.all(np.isfinite(a[name])):
            raise ValueError(f"the {model.kind} model file's {name} has non-finite values")
    return DplPolicy(Scaling(kept, low, high, size), w1, b1, w2, b2)


class _Regression:
    """Eq. 2 on normalized targets plus l2 (|W1|^2 + |W2|^2), as a torch function of the weights."""

    def __init__(self, inputs: np.ndarray, targets: np.ndarray, config: DplConfig):
        self.config = config
        self.u = torch.tensor(inputs, dtype=torch.float64)
        self.targets = torch.tensor(targets, dtype=torch.float64)
        rng = np.random.default_rng(config.seed)
        k, s, m = config.hidden_units, inputs.shape[1], targets.shape[1]
        w1 = rng.normal(0.0, 1.0 / np.sqrt(max(s, 1)), (k, s))
        # each unit's transition through the middle of the data: no unit starts saturated
        b1 = -w1 @ inputs.mean(axis=0)
        w2 = rng.normal(0.0, 1.0 / np.sqrt(k), (m, k))
        b2 = targets.mean(axis=0) - w2 @ sigmoid(b1 + w1 @ inputs.mean(axis=0))
        self.shapes = [(k, s), (k,), (m, k), (m,)]
        self.theta = torch.tensor(
            np.concatenate([w1.ravel(), b1, w2.ravel(), b2]), requires_grad=True
        )

    def _split(self, theta):
        parts, offset = [], 0
        for shape in self.shapes:
            size = int(np.prod(shape))
            parts.append(theta[offset : offset + size].reshape(shape))
            offset += size
        return parts

    def terms(self, theta):
        """(mean squared error, |W1|^2 + |W2|^2) of the normalized targets."""
        w1, b1, w2, b2 = self._split(theta)
        prediction = torch.sigmoid(self.u @ w1.T + b1) @ w2.T + b2
        return torch.mean((prediction - self.targets) ** 2), torch.sum(w1**2) + torch.sum(w2**2)

    def solve(self, report):
        config = self.config

        def loss(iteration):
            error, penalty = self.terms(self.theta)
            total = error + config.l2 * penalty
            report(
                "optimizing",
                min(iteration / config.max_iterations, 1.0),
                {"total": float(total.detach()), "iteration": iteration},
            )
            return total

        threads = torch.get_num_threads()
        torch.set_num_threads(1)
        try:
            iterations = minimize_lbfgs(
                self.theta, loss, config.max_iterations, tolerance_change=1e-14
            )
        finally:
            torch.set_num_threads(threads)
        with torch.no_grad():
            error, penalty = self.terms(self.theta)
        losses = {"total": float(error + config.l2 * penalty), "l2": float(penalty)}
        weights = [t.detach().numpy().copy() for t in self._split(self.theta)]
        return weights, losses, int(iterations)
