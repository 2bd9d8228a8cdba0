"""Objectives of the motion-rate controller, one module each (base, value, dpl), built from model
files here. ROS-free.

make_objective(model_file, robot, period) turns a loaded tric_learning.model_file.ModelFile into the
objective that tric_control.motion_rate.MotionRateController minimizes each tick. Every model kind
the controller can run has its constructor here; the controller node refuses the others.

- "tric": Eq. 8-10, see objectives.value.ValueObjective.
- "dpl_joint", "dpl_finger": the IK scheme of Sec. 5.3.2,
      C_DPL = |dq|^2 + DPL_WEIGHT |A dq - s pi(y)|^2 (+ C_prior: the controller's constraints)
  with A = I for dpl_joint and A = J_f, the Jacobian (3 F, n) of the fingertips' positions in the
  box frame (rows of dphi/dq), for dpl_finger. pi predicts the step per sample period of the
  demonstrations (the paper's 125 ms, the model's sample_period_s); the controller takes one step
  per control period, so s = period / sample_period_s scales it to a tick: the policy's velocity is
  kept, and a demonstration's 5 s take about 5 s (500 ticks at 100 Hz) to imitate. The |dq|^2 term
  is the controller's own; unconstrained, dpl_joint's step is DPL_WEIGHT / (DPL_WEIGHT + 1) s pi(y).
"""

import math
from typing import Any

from tric_control.objectives.base import Objective
from tric_control.objectives.dpl import DPL_WEIGHT, DplObjective
from tric_control.objectives.value import COMPILED, ValueObjective
from tric_learning.features import FeatureMap
from tric_learning.model_file import ModelFile, value_function
from tric_learning.training import dpl
from tric_learning.training.rest import RestRule
from tric_sim.world.robot_model import RobotModel

#: Model kinds make_objective can build an objective for.
RUNNABLE_KINDS = ("tric", "dpl_joint", "dpl_finger")
#: The controller's default control period (100 Hz), s.
CONTROL_PERIOD = 0.01


def make_objective(
    model_file: ModelFile, robot: RobotModel, period: float = CONTROL_PERIOD, rho_scale: float = 1.0
):
    """The controller objective of model_file on robot for a control period (s), or ValueError
    saying why it cannot be run. rho_scale: TRIC's rho is the model's times this (tric-study's
    option for studies of the gain)."""
    if not (math.isfinite(rho_scale) and rho_scale > 0):
        raise ValueError(f"rho_scale must be finite and positive, got {rho_scale!r}")
    if model_file.kind == "tric":
        return _tric_objective(model_file, robot, rho_scale)
    if model_file.kind in dpl.DPL_KINDS:
        return _dpl_objective(model_file, robot, period)
    raise ValueError(
        f"model kind '{model_file.kind}' cannot be run by this controller "
        f"(runnable kinds: {', '.join(RUNNABLE_KINDS)})"
    )


def _tric_objective(model_file: ModelFile, robot: RobotModel, rho_scale: float) -> ValueObjective:
    """TRIC (Eq. 8-10): rho (g^T dq + delta)^2 with the model's value function f and its delta,
    rho (times rho_scale)."""
    numbers = {}
    for name in ("delta", "rho"):
        value: Any = model_file.info.get(name)  # anything the file holds
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ValueError(
                f"the TRIC model has no usable '{name}' in its info ({value!r})"
            ) from None
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"the TRIC model's {name} must be finite and positive, got {value!r}")
        numbers[name] = value
    rest = model_file.info.get("rest")  # None: a model made before models carried their rule
    done: Any = model_file.info.get("done_value")  # None: chosen by no selection
    if done is not None:
        try:
            done = float(done)
        except (TypeError, ValueError):
            done = math.nan
        if not math.isfinite(done):
            raise ValueError(
                f"the TRIC model's done_value must be a finite number, got "
                f"{model_file.info.get('done_value')!r}"
            )
    return ValueObjective(
        FeatureMap(model_file.definition, robot),
        value_function(model_file),
        numbers["delta"],
        numbers["rho"] * rho_scale,
        rest=None if rest is None else RestRule.from_dict(rest),
        done_value=done,
    )


def _dpl_objective(model_file: ModelFile, robot: RobotModel, period: float) -> "DplObjective":
    """C_DPL of a dpl_joint or dpl_finger model, its policy's steps scaled from the model's sample
    period to the control period."""
    if not (math.isfinite(period) and period > 0):
        raise ValueError(f"the control period must be finite and positive, got {period!r}")
    try:
        sample_period: Any = model_file.info.get("sample_period_s")  # anything the file holds
        try:
            sample_period = float(sample_period)
        except (TypeError, ValueError):
            raise ValueError(
                f"it has no usable 'sample_period_s' in its info ({sample_period!r})"
            ) from None
        if not (math.isfinite(sample_period) and sample_period > 0):
            raise ValueError(
                f"its sample_period_s must be finite and positive, got {sample_period!r}"
            )
        rows = dpl.finger_rows(model_file.definition) if model_file.kind == "dpl_finger" else None
        return DplObjective(
            FeatureMap(model_file.definition, robot),
            dpl.load_policy(model_file),
            period / sample_period,
            rows,
        )
    except ValueError as error:
        raise ValueError(f"the {model_file.kind} model cannot be run: {error}") from None


__all__ = [
    "COMPILED",
    "CONTROL_PERIOD",
    "DPL_WEIGHT",
    "RUNNABLE_KINDS",
    "DplObjective",
    "Objective",
    "ValueObjective",
    "make_objective",
]
