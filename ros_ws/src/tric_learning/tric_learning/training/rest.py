"""When the learned controller has done its task: the rest rule, taken from the demonstrations
(paper Sec. 5.4: a minimum of f where the demonstrations end holds the controller there). ROS-free.
Units: rad, s, and f's own.

Both of the rule's thresholds are over a window of REST_WINDOW_S, as the controller judges them
(tric_control.motion_rate), and both come from the demonstrations:
- the step: the joints' speed |q(t) - q(t - window)| / window below the slowest the teacher moves
  over any window that ends while it is still on its way (farther from its end state than
  REST_MARGIN of its whole way, in joint space): slower than the teacher ever is before its end;
- f has stopped falling: f falls over the window at under REST_FALL_SHARE of the pace it falls
  along the demonstrations (their median of (f(y_0) - f(y_T)) / duration, the pace the
  controller's delta asks for, Sec. 5.2.3).
Measured on real models (docs/decisions/rest-and-grip.md): the teacher stops dead at its end
(0.001 rad/s), the controller never quite does (it creeps at 0.004 to 0.02 rad/s where the hand has
arrived, f falling at under 1% of its pace), so a rule taken from the teacher's very last sample
declared no rest at all.

A rule is checked on the demonstrations it came from (check_rest_rule): it must not hold over a
window that ends with a demonstration still on its way; a rule taken from a demonstration's middle
is refused so.
"""

from dataclasses import asdict, dataclass

import numpy as np

from tric_learning.training.dataset import Dataset
from tric_learning.value_function import ValueFunction

#: The span of time the controller's rest is judged over, s (four of the demonstrations' 125 ms
#: samples).
REST_WINDOW_S = 0.5
#: How far from its end state a demonstration may still be, as a share of its way from its start,
#: where the rule holds along it.
REST_MARGIN = 0.1
#: f has stopped falling when it falls at under this share of its pace along the demonstrations.
REST_FALL_SHARE = 0.02


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


def window_rates(model: ValueFunction, demo, window_s: float = REST_WINDOW_S) -> tuple:
    """Over each window of about window_s (whole samples, at least one) along a demonstration:
    (joint speed (n,), rad/s; f's fall (n,), per s; how far the window's end still is from the
    demonstration's end state, as a share of its whole way (n,)). n = 0 for a demonstration
    shorter than a window."""
    seconds = np.asarray(demo.stamps_ns, dtype=float) * 1e-9
    span = max(int(round(window_s / float(np.median(np.diff(seconds))))), 1)
    values = model.value(demo.y)
    elapsed = seconds[span:] - seconds[:-span]
    speed = np.linalg.norm(demo.q[span:] - demo.q[:-span], axis=1) / elapsed
    way = max(float(np.linalg.norm(demo.q[0] - demo.q[-1])), 1e-12)
    left = np.linalg.norm(demo.q[span:] - demo.q[-1], axis=1) / way
    return speed, (values[:-span] - values[span:]) / elapsed, left


def rest_rule(model: ValueFunction, dataset: Dataset) -> RestRule | None:
    """The rule of the module docstring for model on its demonstrations, checked
    (check_rest_rule); None where no demonstration is on its way for a whole window (too short to
    say how slowly the teacher moves on its way: the controller then judges rest by its own
    rule)."""
    on_way, paces = [], []
    for demo in dataset.demos:
        speed, _, left = window_rates(model, demo)
        on_way.append(speed[left > REST_MARGIN])
        values = model.value(demo.y[[0, -1]])
        paces.append((values[0] - values[1]) / ((demo.stamps_ns[-1] - demo.stamps_ns[0]) * 1e-9))
    slowest = np.concatenate(on_way)
    if slowest.size == 0:
        return None
    pace = float(np.median(paces))
    rule = RestRule(max(float(slowest.min()), 1e-6), REST_FALL_SHARE * max(pace, 0.0))
    check_rest_rule(rule, model, dataset)
    return rule


def rest_info(model: ValueFunction, dataset: Dataset) -> dict | None:
    """rest_rule's rule as a model file's info holds it (RestRule.to_dict), or None."""
    rule = rest_rule(model, dataset)
    return None if rule is None else rule.to_dict()


def check_rest_rule(rule: RestRule, model: ValueFunction, dataset: Dataset) -> None:
    """ValueError naming the demonstration and sample where rule holds (the joint speed and f's
    fall over its window) with the demonstration still more than REST_MARGIN of its way from its
    end state."""
    for demo in dataset.demos:
        speeds, falls, left = window_rates(model, demo, rule.window_s)
        for k, (speed, fall) in enumerate(zip(speeds, falls)):
            if rule.holds(speed, fall) and left[k] > REST_MARGIN:
                sample = demo.length - len(speeds) + k
                raise ValueError(
                    f"a rest rule of {rule.speed:.3g} rad/s and an f falling {rule.fall:.3g} per "
                    f"s would declare rest at sample {sample} of {demo.length} of demo "
                    f"'{demo.name}', {left[k]:.0%} of its way still ahead: rest comes too early"
                )
