"""TRIC's objective (Eq. 8-10): rho (g^T dq + delta)^2 with g the gradient of f(phi(q)), and its
domain rows; evaluated by the compiled kernel where it is built. ROS-free."""

import math

import numpy as np

from tric_control.motion_rate import DOMAIN_MARGIN, DOMAIN_ROWS
from tric_control.objectives.base import Objective
from tric_learning.features import FeatureMap
from tric_learning.value_function import ValueFunction

try:
    # (a compiled extension module: the type checker does not see it)
    from tric_control import _value_kernel  # type: ignore[attr-defined]
except ImportError as error:  # not built: the numpy objective
    _value_kernel, _KERNEL_ERROR = None, error
#: Whether the compiled objective (tric_control._value_kernel) is built.
COMPILED = _value_kernel is not None


class ValueObjective:
    """TRIC's objective: rho (g^T dq + delta)^2 with g = (df/dy)(dphi/dq) at q.

    Its domain rows: the DOMAIN_ROWS kept features nearest the bounds of their training range
    (scaled u in [-DOMAIN_MARGIN, 1 + DOMAIN_MARGIN]) among those a step can change (not, say, an
    object's position seen from the robot's base), nearest first: the gradients du/dq of their
    margins (the upper bound's margin falls as u rises), the margins and their names. After each
    call, scaled_features (s,) and value_gradient (s,) hold u and df/du at that q (for the
    status).

    compiled: evaluate with tric_control._value_kernel (C++, built by colcon with this package):
    True requires it, False uses the numpy code (the reference the kernel is tested against),
    None (default) the kernel where it is built and feature_map and value_function are a
    tric_learning FeatureMap and ValueFunction. The two agree to rounding (1e-12), not bit for
    bit; COMPILED says whether the kernel is built. rest: the model's rest rule
    (tric_learning.training.rest.RestRule), or None (the controller's own, for models made before
    models carried one or trained on demonstrations too short to give one). done_value: f where
    the model's own rollouts from its demonstrations' starts came to rest (the selection's median;
    tric_control.stall_escape), or None (a model chosen by no selection).
    """

    def __init__(
        self,
        feature_map,
        value_function,
        delta: float,
        rho: float,
        feature_names=None,
        compiled: bool | None = None,
        rest=None,
        done_value: float | None = None,
    ):
        if not (delta > 0 and rho > 0):
            raise ValueError("delta and rho must be positive")
        self.features, self.value_function, self.delta, self.rho = (
            feature_map,
            value_function,
            delta,
            rho,
        )
        self.rest = rest
        self.done_value = done_value
        scaling = value_function.scaling
        names = feature_names or feature_map.definition.feature_names
        self.kept_names = [names[k] for k in scaling.kept]
        self._kept, self._low, self._span = scaling.kept, scaling.low, scaling.high - scaling.low
        self._factor = scaling.factor
        self._weights = np.zeros(scaling.size)  # df/dy on the raw features
        moving = np.flatnonzero(feature_map.moves_with_q[scaling.kept])
        self._moving, self._moving_raw, self._moving_factor = (
            moving,
            scaling.kept[moving],
            self._factor[moving],
        )
        self.scaled_features: np.ndarray | None = None
        self.value_gradient: np.ndarray | None = None
        self._kernel = self._compiled_kernel(compiled)

    def _compiled_kernel(self, compiled: bool | None):
        """The compiled kernel for this objective, or None (see the class docstring)."""
        if compiled is False:
            return None
        usable = isinstance(self.features, FeatureMap) and isinstance(
            self.value_function, ValueFunction
        )
        if not (COMPILED and usable):
            if compiled:
                raise ValueError(
                    "the compiled objective needs tric_control._value_kernel (built by colcon "
                    "with tric_control) and a FeatureMap with a ValueFunction"
                    + ("" if COMPILED else f"; the kernel did not import: {_KERNEL_ERROR}")
                )
            return None
        features, function, robot = self.features, self.value_function, self.features.robot
        pairs = np.array(features.definition.pairs).reshape(-1, 2)
        return _value_kernel.ValueKernel(
            len(features.definition.landmark_names),
            pairs[:, 0],
            pairs[:, 1],
            features.relative_supports,
            robot.extended_to_q.argmax(axis=1),
            robot.n_joints,
            self._kept,
            self._low,
            self._span,
            self._factor,
            function.w1.reshape(function.hidden_units, len(self._kept)),
            function.w2,
            function.w3,
            function.b1,
            self._moving,
            DOMAIN_ROWS,
            DOMAIN_MARGIN,
            self.rho,
            self.delta,
        )

    def __call__(self, q, object_poses) -> Objective:
        if self._kernel is None:
            return self._evaluate(q, object_poses)
        features = self.features
        placements = features.landmark_placements(np.asarray(q, dtype=float), object_poses)
        value, u, df_du, g, hessian, linear, norm, rows, margins, nearest = self._kernel.evaluate(
            placements, features.robot.data.J
        )
        self.scaled_features, self.value_gradient = u, df_du
        return Objective(
            hessian=hessian,
            linear=linear,
            value=value,
            gradient_norm=norm,
            gradient=g,
            domain_rows=rows,
            domain_margins=margins,
            domain_names=[self.kept_names[k] for k in nearest.tolist()],
        )

    def _evaluate(self, q, object_poses) -> Objective:
        """The objective at q with numpy (the reference)."""
        y, jacobian = self.features.with_jacobian(q, object_poses)
        u = (y.take(self._kept) - self._low) / self._span
        value, df_du = self.value_function.scaled_gradient(u)
        self.scaled_features, self.value_gradient = u, df_du
        weights = self._weights
        weights[self._kept] = df_du * self._factor
        g = weights @ jacobian
        scaled = u.take(self._moving)
        to_low, to_high = scaled + DOMAIN_MARGIN, (1.0 + DOMAIN_MARGIN) - scaled
        margins = np.minimum(to_low, to_high)
        nearest = margins.argsort()[:DOMAIN_ROWS]
        signs = np.where(to_low.take(nearest) <= to_high.take(nearest), 1.0, -1.0)
        rows = (
            jacobian.take(self._moving_raw.take(nearest), axis=0)
            * (self._moving_factor.take(nearest) * signs)[:, None]
        )
        two_rho = 2.0 * self.rho
        return Objective(
            hessian=two_rho * (g[:, None] * g),
            linear=two_rho * self.delta * g,
            value=value,
            gradient_norm=math.sqrt(g @ g),
            gradient=g,
            domain_rows=rows,
            domain_margins=margins.take(nearest),
            domain_names=[self.kept_names[k] for k in self._moving.take(nearest).tolist()],
        )
