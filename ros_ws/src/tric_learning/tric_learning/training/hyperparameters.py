"""The hyper-parameters of the two kinds of model, TRIC's value function (TrainingConfig,
tric_learning.training.value) and the DPL baseline's policy (DplConfig, tric_learning.training.dpl),
with the names of the model kinds: plain dataclasses that import neither torch nor the robot model,
so that tric-train answers --help and refuses bad values before it loads either."""

from dataclasses import asdict, dataclass

import numpy as np

#: The model kinds a model file holds: TRIC's value function and DPL's two policies.
DPL_KINDS = ("dpl_joint", "dpl_finger")
KINDS = ("tric", *DPL_KINDS)
#: How deep a noisy sample may press into the bodies the task lets the hand touch, m: the teacher's
#: own grip presses 8 to 9 mm into a sphere's collision shape, so this admits its grasps (at 5 mm
#: only 9% of the last steps' demonstrated states were collision-free).
SAMPLE_CONTACT_TOLERANCE = 0.015
#: The optimizers TrainingConfig.optimizer names.
OPTIMIZERS = ("lbfgs", "lbfgsb", "bfgs")
#: The weightings of L_g's steps TrainingConfig.lg_weighting names.
LG_WEIGHTINGS = ("none", "length")


def refuse_failed(checks) -> None:
    """ValueError with the message of the first (ok, message) of checks that is not ok; a config's
    validate() lists its checks so (TrainingConfig's, dpl.DplConfig's)."""
    for ok, message in checks:
        if not ok:
            raise ValueError(message)


@dataclass
class TrainingConfig:
    """Hyper-parameters: the paper's defaults but alpha_g, max_iterations and L_g's weighting
    (tric_learning.training.value's docstring; each departure measured in docs/fidelity.md).

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
    #: sparse); "bfgs": SciPy's BFGS in float64 on the whole loss (the paper's optimizer).
    optimizer: str = "lbfgs"
    #: How deep a noisy sample may press into the bodies the task lets the hand touch, m
    #: (SAMPLE_CONTACT_TOLERANCE: the teacher's own grip).
    sample_contact_tolerance: float = SAMPLE_CONTACT_TOLERANCE
    #: The scene of step t's noisy samples: the objects of step t + sample_scene_step (-1: those of
    #: q_{t-1}, whose perturbations the samples are; 0: those of the demonstrated y_t they are
    #: contrasted with).
    sample_scene_step: int = -1
    #: L_g's steps: those of at least lg_min_step rad (0: every step, as Eq. 11 sums them), each
    #: step's cosine weighted by its length |q_{t+1} - q_t| over the mean length ("length") or by
    #: 1 ("none", Eq. 11).
    lg_min_step: float = 0.0
    lg_weighting: str = "length"
    #: The hold: M noisy samples around each demonstration's last state, contrasted in L_n with
    #: that state itself (training.samples.generate's hold), so that f has its minimum where the
    #: demonstrations end (an addition to the paper; off, as the paper, since no task's validation
    #: sets showed a gain their noise resolves: docs/decisions/rest-and-grip.md).
    hold_samples: bool = False
    #: The weight of L_e, f's squared gradient at each demonstration's last state over its mean
    #: square along the way (training.problem), so that f is flat where the demonstrations end (an
    #: addition to the paper; 0: off).
    end_flatness: float = 0.0
    #: Biases b1 in the hidden layer, z = sigmoid(W1 u + b1) (the paper's model has none).
    hidden_bias: bool = False
    #: The optimization in float64, as the paper's BFGS (the default float32 is faster).
    float64: bool = False

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
            (
                self.end_flatness >= 0 and np.isfinite(self.end_flatness),
                "end_flatness must be finite and >= 0",
            ),
            (1 <= self.max_iterations <= 100000, "max_iterations must be in [1, 100000]"),
            (0 < self.correlation_threshold <= 1, "correlation_threshold must be in (0, 1]"),
            (0 <= self.seed < 2**32, "seed must be in [0, 2^32)"),
            (self.optimizer in OPTIMIZERS, f"optimizer must be one of {', '.join(OPTIMIZERS)}"),
            (
                0 <= self.sample_contact_tolerance <= 0.1,
                "sample_contact_tolerance must be in [0, 0.1] m",
            ),
            (self.sample_scene_step in (0, -1), "sample_scene_step must be 0 or -1"),
            (0 <= self.lg_min_step < 1, "lg_min_step must be in [0, 1) rad"),
            (
                self.lg_weighting in LG_WEIGHTINGS,
                f"lg_weighting must be one of {', '.join(LG_WEIGHTINGS)}",
            ),
        ]
        refuse_failed(checks)
        return self

    def to_dict(self) -> dict:
        return asdict(self)


@dataclass
class DplConfig:
    """Hyper-parameters (l2's default: docs/decisions/dpl-settings.md).

    hidden_units: K sigmoid units (the paper: 60), a count.
    l2: the weight on |W1|^2 + |W2|^2, relative to the mean squared error of the RMS-normalized
        targets (dimensionless).
    max_iterations: L-BFGS iterations at most.
    correlation_threshold: the input scaling's (as TRIC's), a correlation in (0, 1].
    seed: the seed of the initial weights.
    """

    hidden_units: int = 60
    l2: float = 1e-4
    max_iterations: int = 300
    correlation_threshold: float = 0.995
    seed: int = 0

    def validate(self) -> "DplConfig":
        """Return self, or ValueError naming the first value out of range."""
        checks = [
            (1 <= self.hidden_units <= 1000, "hidden_units must be in [1, 1000] for DPL"),
            (np.isfinite(self.l2) and self.l2 >= 0, "l2 must be finite and >= 0"),
            (1 <= self.max_iterations <= 100000, "max_iterations must be in [1, 100000]"),
            (0 < self.correlation_threshold <= 1, "correlation_threshold must be in (0, 1]"),
            (0 <= self.seed < 2**32, "seed must be in [0, 2^32)"),
        ]
        refuse_failed(checks)
        return self

    def to_dict(self) -> dict:
        return asdict(self)
