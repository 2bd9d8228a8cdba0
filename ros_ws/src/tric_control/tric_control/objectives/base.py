"""The quadratic model every objective of the motion-rate controller gives at q. ROS-free."""

from dataclasses import dataclass, field

import numpy as np


@dataclass
class Objective:
    """An objective's quadratic model at q: 1/2 dq^T hessian dq + linear^T dq, the cost's value and
    gradient norm, and the domain rows: the gradients (k, n) of margins (k,) that must stay >= 0,
    nearest their bound first, with the names of their features. gradient: the gradient (n,) of the
    learned value in q, for an objective that has one (else None)."""

    hessian: np.ndarray
    linear: np.ndarray
    value: float
    gradient_norm: float
    gradient: np.ndarray | None = None
    domain_rows: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)))
    domain_margins: np.ndarray = field(default_factory=lambda: np.zeros(0))
    domain_names: list = field(default_factory=list)
