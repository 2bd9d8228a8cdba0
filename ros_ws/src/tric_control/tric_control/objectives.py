"""Objectives of the motion-rate controller, built from model files. ROS-free.

make_objective(model_file, robot) turns a loaded tric_learning.model_file.ModelFile into the
objective that tric_control.motion_rate.MotionRateController minimizes each tick. Every model kind the
controller can run has its constructor here; the controller node refuses the others.
"""

import math

from tric_learning.features import FeatureMap
from tric_learning.model_file import ModelFile, value_function
from tric_sim.robot_model import RobotModel

from tric_control.motion_rate import ValueObjective

#: Model kinds make_objective can build an objective for.
RUNNABLE_KINDS = ("tric",)


def make_objective(model_file: ModelFile, robot: RobotModel):
    """The controller objective of model_file on robot, or ValueError saying why it cannot be run."""
    if model_file.kind == "tric":
        return _tric_objective(model_file, robot)
    raise ValueError(f"model kind '{model_file.kind}' cannot be run by this controller "
                     f"(runnable kinds: {', '.join(RUNNABLE_KINDS)})")


def _tric_objective(model_file: ModelFile, robot: RobotModel) -> ValueObjective:
    """TRIC (Eq. 8-10): rho (g^T dq + delta)^2 with the model's value function f and its delta, rho."""
    numbers = {}
    for name in ("delta", "rho"):
        value = model_file.info.get(name)
        try:
            value = float(value)
        except (TypeError, ValueError):
            raise ValueError(f"the TRIC model has no usable '{name}' in its info ({value!r})") from None
        if not (math.isfinite(value) and value > 0):
            raise ValueError(f"the TRIC model's {name} must be finite and positive, got {value!r}")
        numbers[name] = value
    return ValueObjective(FeatureMap(model_file.definition, robot), value_function(model_file),
                         numbers["delta"], numbers["rho"])
