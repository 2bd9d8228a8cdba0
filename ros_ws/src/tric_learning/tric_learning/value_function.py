"""The value function f(y; w) of TRIC (paper Eq. 19-20) with its preprocessing, for inference.

Preprocessing (Sec. 5.2.1): each feature is rescaled to [0, 1] over the training demonstrations
(u = (y - low) / (high - low)); features that barely vary (range below MIN_RANGE: the demonstrations
never moved them, so rescaling would blow up noise) and features whose absolute correlation with an
earlier kept feature exceeds a threshold are dropped. The model on the s kept, scaled features u is

    f = z^T W2 + u^T W3,    z = sigmoid(W1 u + b1)

with K sigmoid units (K = 0: the linear model), W1 (K, s), W2 (K,), W3 (s,), and the hidden
units' biases b1 (K,), zero in the paper's model (a training option adds them). (The paper writes
z = 1 / (1 + e^{W1 y}), i.e. sigmoid(-W1 y); the sign is absorbed into W1. Its "W3 in R^K" is a
typo for R^s.) Gradients are analytic: df/du = W1^T (W2 * z * (1 - z)) + W3, and df/dy on the raw
features is that divided by (high - low), zero on dropped features.
"""

from dataclasses import dataclass

import numpy as np

#: Features varying by less than this over the training data are dropped, m.
MIN_RANGE = 1e-3


@dataclass
class Scaling:
    """Which raw features are kept (kept: (s,) indices into d) and their range (low, high: (s,))."""

    kept: np.ndarray
    low: np.ndarray
    high: np.ndarray
    size: int  # d, the number of raw features

    @classmethod
    def fit(cls, y: np.ndarray, correlation_threshold: float) -> "Scaling":
        """Fit on raw feature samples y (S, d)."""
        if not 0 < correlation_threshold <= 1:
            raise ValueError("correlation_threshold must be in (0, 1]")
        y = np.asarray(y, dtype=float)
        low, high = y.min(axis=0), y.max(axis=0)
        varying = np.flatnonzero(high - low > MIN_RANGE)
        scaled = (y[:, varying] - low[varying]) / (high[varying] - low[varying])
        correlation = np.abs(np.corrcoef(scaled, rowvar=False))
        kept: list[int] = []
        for k in range(len(varying)):
            if all(correlation[k, j] <= correlation_threshold for j in kept):
                kept.append(k)
        chosen = varying[kept]
        return cls(chosen, low[chosen], high[chosen], y.shape[1])

    def transform(self, y: np.ndarray) -> np.ndarray:
        """Scaled kept features (..., s) of raw features (..., d)."""
        return (np.asarray(y)[..., self.kept] - self.low) / (self.high - self.low)

    @property
    def factor(self) -> np.ndarray:
        """du/dy of the kept features, (s,)."""
        return 1.0 / (self.high - self.low)

    @classmethod
    def union(cls, scalings) -> "Scaling":
        """The smallest Scaling that spans every one of scalings (of d features alike): the
        features any of them keeps, each over the widest range any of them gives it. ValueError for
        none, or scalings of other feature counts."""
        scalings = list(scalings)
        if not scalings or len({scaling.size for scaling in scalings}) != 1:
            raise ValueError("a union needs at least one scaling, all of the same feature count")
        kept = np.unique(np.concatenate([scaling.kept for scaling in scalings]))
        low, high = np.full(len(kept), np.inf), np.full(len(kept), -np.inf)
        for scaling in scalings:
            where = np.searchsorted(kept, scaling.kept)
            low[where] = np.minimum(low[where], scaling.low)
            high[where] = np.maximum(high[where], scaling.high)
        return cls(kept, low, high, scalings[0].size)


@dataclass
class ValueFunction:
    """f(y; w) of Eq. 19-20 on raw features through its Scaling (see the module docstring)."""

    scaling: Scaling
    w1: np.ndarray
    w2: np.ndarray
    w3: np.ndarray
    b1: np.ndarray | None = None  # (K,); None: zeros, the paper's model

    def __post_init__(self):
        if self.b1 is None:
            self.b1 = np.zeros(len(self.w2))

    @property
    def hidden_units(self) -> int:
        return len(self.w2)

    def value(self, y: np.ndarray) -> np.ndarray:
        """f of raw features y (..., d) -> (...)."""
        u = self.scaling.transform(y)
        value = u @ self.w3
        if self.hidden_units:
            value = value + sigmoid(u @ self.w1.T + self.b1) @ self.w2
        return value

    def gradient(self, y: np.ndarray):
        """(f, df/dy) at raw features y (d,): a scalar and (d,), zero on dropped features."""
        value, du = self.scaled_gradient(self.scaling.transform(y))
        full = np.zeros(self.scaling.size)
        full[self.scaling.kept] = du * self.scaling.factor
        return value, full

    def scaled_gradient(self, u: np.ndarray):
        """(f, df/du) at scaled kept features u (s,): a scalar and (s,)."""
        value = float(u @ self.w3)
        if not self.hidden_units:
            return value, self.w3.copy()
        z = sigmoid(self.w1 @ u + self.b1)
        value += float(z @ self.w2)
        return value, self.w3 + self.w1.T @ (self.w2 * z * (1.0 - z))

    def on_scaling(self, target: Scaling) -> "ValueFunction":
        """The same f, less a constant, on target, a Scaling that keeps every feature this one
        keeps (Scaling.union): each kept u_k = a_k u + c_k of target's u, so W1 and W3 take the
        factors a, the hidden biases take W1 c, and the constant W3 . c is dropped (f's gradient
        and its differences, all that the controller and its delta use, are unchanged).
        ValueError if target lacks one of the features."""
        where = np.searchsorted(target.kept, self.scaling.kept)
        inside = where < len(target.kept)
        if target.size != self.scaling.size or not (
            np.all(inside) and np.array_equal(target.kept[where], self.scaling.kept)
        ):
            raise ValueError("the target scaling must keep every feature of the value function's")
        span = self.scaling.high - self.scaling.low
        factor = (target.high[where] - target.low[where]) / span
        shift = (target.low[where] - self.scaling.low) / span
        w1 = np.zeros((self.hidden_units, len(target.kept)))
        w1[:, where] = self.w1 * factor
        w3 = np.zeros(len(target.kept))
        w3[where] = self.w3 * factor
        return ValueFunction(target, w1, self.w2.copy(), w3, self.b1 + self.w1 @ shift)

    @classmethod
    def ensemble(cls, members: list, weights) -> "ValueFunction":
        """The weighted sum f = sum_k weights_k f_k of value functions on one Scaling, as one
        ValueFunction: their hidden units side by side (W1 stacked, W2 joined, each scaled by its
        weight) and W3 = sum_k weights_k W3_k. ValueError for no members, members on other
        scalings, or weights of another count or not finite."""
        weights = np.asarray(weights, dtype=float)
        if not members:
            raise ValueError("an ensemble needs at least one member")
        if weights.shape != (len(members),) or not np.all(np.isfinite(weights)):
            raise ValueError(f"an ensemble of {len(members)} needs as many finite weights")
        scaling = members[0].scaling
        for member in members[1:]:
            same = (
                member.scaling.size == scaling.size
                and np.array_equal(member.scaling.kept, scaling.kept)
                and np.array_equal(member.scaling.low, scaling.low)
                and np.array_equal(member.scaling.high, scaling.high)
            )
            if not same:
                raise ValueError("the members of an ensemble must share one Scaling")
        return cls(
            scaling,
            np.vstack([member.w1 for member in members]),
            np.concatenate([weight * member.w2 for weight, member in zip(weights, members)]),
            sum(weight * member.w3 for weight, member in zip(weights, members)),
            np.concatenate([member.b1 for member in members]),
        )

    def scores(self) -> np.ndarray:
        """Each kept feature's contribution s(y) = |W1^T| |W2| + |W3| (Sec. 5.5.1), (s,)."""
        score = np.abs(self.w3).copy()
        if self.hidden_units:
            score += np.abs(self.w1).T @ np.abs(self.w2)
        return score


def sigmoid(x):
    """The logistic function 1 / (1 + exp(-x)), elementwise, written with tanh (no overflow)."""
    return 0.5 * (1.0 + np.tanh(0.5 * x))
