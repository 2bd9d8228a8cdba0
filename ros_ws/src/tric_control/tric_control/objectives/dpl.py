"""DPL's objective (Sec. 5.3.2), C_DPL without the controller's |dq|^2; see
tric_control.objectives for the scheme. ROS-free."""

import math

import numpy as np

from tric_control.objectives.base import Objective
from tric_learning.features import FeatureMap
from tric_learning.training import dpl

#: C_DPL's weight on following the policy (Sec. 5.3.2: 10^3), relative to |dq|^2.
DPL_WEIGHT = 1e3


class DplObjective:
    """C_DPL (see the module docstring) without the controller's |dq|^2: DPL_WEIGHT |A dq - s
    pi(y)|^2, A = I (rows None: the policy predicts joint steps) or the feature Jacobian's rows (the
    policy predicts those features' steps). Its value is NaN: a policy has no cost to report."""

    def __init__(
        self, feature_map: FeatureMap, policy: dpl.DplPolicy, step_scale: float, rows=None
    ):
        if not step_scale > 0:
            raise ValueError("step_scale must be positive")
        self.features, self.policy, self.step_scale, self.rows = (
            feature_map,
            policy,
            step_scale,
            rows,
        )
        #: A policy has no rest rule: the controller's own applies.
        self.rest = None

    def __call__(self, q, object_poses) -> Objective:
        if self.rows is None:
            target = self.step_scale * self.policy.predict(self.features(q, object_poses))
            hessian = 2.0 * DPL_WEIGHT * np.eye(len(target))
            linear = -2.0 * DPL_WEIGHT * target
        else:
            y, jacobian = self.features.with_jacobian(q, object_poses)
            target = self.step_scale * self.policy.predict(y)
            rows = jacobian[self.rows]
            hessian = 2.0 * DPL_WEIGHT * rows.T @ rows
            linear = -2.0 * DPL_WEIGHT * rows.T @ target
        return Objective(
            hessian=hessian,
            linear=linear,
            value=math.nan,
            gradient_norm=float(np.linalg.norm(linear)),
        )
