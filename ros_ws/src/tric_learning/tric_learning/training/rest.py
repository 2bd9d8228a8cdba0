"""When the learned controller has done its task: the rest rule, taken from where the
demonstrations end (paper Sec. 5.4: a minimum of f where the demonstrations end holds the
controller there). ROS-free. Units: rad, s, and f's own.

The teacher is at its task's end when it moves as slowly as it does over its demonstrations' last
sample, and f (learned) falls there as slowly as it falls over that sample. The rule takes both
from the demonstrations: the median over them of the joints' speed |q_{T-1} - q_{T-2}| / dt and of
f's fall (f(y_{T-2}) - f(y_{T-1})) / dt over their last sample, at least 0. The controller is at
rest when, over the last RestRule.window_s, its joints moved slower than the one and f fell slower
than the other (tric_control.motion_rate).

A rule is checked on the demonstrations it came from (check_rest_rule): it must not hold over a
demonstration's sample that ends farther from the demonstration's end state than REST_MARGIN of
its whole way (in joint space: the demonstration itself says where it is still on its way); a rule
taken from a demonstration's middle (a speed of the middle's, a fall of the middle's) is refused
so.
"""

from dataclasses import asdict, dataclass

import numpy as np

from tric_learning.training.dataset import Dataset
from tric_learning.value_function import ValueFunction

#: The span of time the controller's rest is judged over, s (two of the demonstrations' 125 ms
#: samples).
REST_WINDOW_S = 0.25
#: How far from its end state a demonstration may still be, as a share of its way from its start,
#: where the rule holds along it.
REST_MARGIN = 0.1


@dataclass(frozen=True)
class RestRule:
    """At rest: over window_s, joint speed below speed (rad/s, the norm of the change over the
    window by its length) and f's fall below fall (f per s; f rising counts as no fall)."""

    speed: float
    fall: float
    window_s: float = REST_WINDOW_S

    def holds(self, speed: float, fall: float) -> bool:
        return bool(speed < self.speed and fall <= self.fall)

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, data) -> "RestRule":
        """The rule of to_dict()'s data (read from a model file); ValueError if it is not one."""
        try:
            rule = cls(float(data["speed"]), float(data["fall"]), float(data["window_s"]))
        except (TypeError, KeyError, ValueError):
            raise ValueError(f"not a rest rule: {str(data)[:80]}") from None
        values = (rule.speed, rule.fall, rule.window_s)
        if not all(np.isfinite(values)) or rule.speed <= 0 or rule.fall < 0 or rule.window_s <= 0:
            raise ValueError(f"a rest rule needs a positive speed and window, a fall >= 0: {rule}")
        return rule


def demo_rates(model: ValueFunction, demo) -> tuple:
    """(joint speed (T - 1,), rad/s; f's fall (T - 1,), per s; f (T,)) over each sample of a
    demonstration."""
    dt = np.diff(demo.stamps_ns) * 1e-9
    values = model.value(demo.y)
    speed = np.linalg.norm(np.diff(demo.q, axis=0), axis=1) / dt
    return speed, -np.diff(values) / dt, values


def rest_rule(model: ValueFunction, dataset: Dataset) -> RestRule:
    """The rule of the module docstring for model on its demonstrations, checked
    (check_rest_rule)."""
    ends = [demo_rates(model, demo) for demo in dataset.demos]
    speed = float(np.median([speeds[-1] for speeds, _, _ in ends]))
    fall = float(max(np.median([falls[-1] for _, falls, _ in ends]), 0.0))
    rule = RestRule(max(speed, 1e-6), fall)
    check_rest_rule(rule, model, dataset)
    return rule


def check_rest_rule(rule: RestRule, model: ValueFunction, dataset: Dataset) -> None:
    """ValueError naming the demonstration and sample where rule holds (its joint speed and f's
    fall over the sample) with the demonstration still more than REST_MARGIN of its way from its
    end state."""
    for demo in dataset.demos:
        speeds, falls, _ = demo_rates(model, demo)
        way = np.linalg.norm(demo.q[0] - demo.q[-1])
        for t, (speed, fall) in enumerate(zip(speeds, falls)):
            left = float(np.linalg.norm(demo.q[t + 1] - demo.q[-1]))
            if rule.holds(speed, fall) and way > 0 and left > REST_MARGIN * way:
                raise ValueError(
                    f"a rest rule of {rule.speed:.3g} rad/s and an f falling {rule.fall:.3g} per "
                    f"s would declare rest at sample {t + 1} of {demo.length} of demo "
                    f"'{demo.name}', {left / way:.0%} of its way still ahead: rest comes too "
                    "early"
                )
