"""The asked fall's pace: an option of the motion-rate controller (docs/decisions/fall-pace.md).
ROS-free.

TRIC asks f to fall by delta every tick (Sec. 5.2.3), predicting the fall from f's gradient with the
objects held still. Where the world does not follow the prediction (the fingers blocked on the
object while the arm pushes it along, f's level unchanged), the paper's controller keeps asking,
and the arm keeps moving. With a FallPace the controller compares, over a window, the fall that
happened with the fall it asked, and asks a share of delta:

    share = clip((realized / asked) / knee, floor, 1)

realized and asked being exponential averages over window_ticks of each tick's fall of f and of
the fall asked on the tick before (both in units of delta). While f falls as asked the share stays 1
(the paper's step); once it falls less than knee of what is asked, the asked fall shrinks with it,
down to floor, and the step with it, until f falls as asked again.
"""

from dataclasses import dataclass


@dataclass(frozen=True)
class FallPace:
    """The pace's settings: knee (the realized share of the asked fall below which the ask
    shrinks, in (0, 1]), window_ticks (the averages' time constant, ticks >= 1) and floor (the
    smallest share of delta asked, in (0, 1]). start() gives one episode's state."""

    knee: float = 0.25
    window_ticks: float = 50.0
    floor: float = 0.05

    def __post_init__(self):
        if not 0 < self.knee <= 1:
            raise ValueError(f"the fall pace's knee must be in (0, 1], not {self.knee}")
        if not self.window_ticks >= 1:
            raise ValueError(f"the fall pace's window must be >= 1 tick, not {self.window_ticks}")
        if not 0 < self.floor <= 1:
            raise ValueError(f"the fall pace's floor must be in (0, 1], not {self.floor}")

    @classmethod
    def for_objective(cls, knee: float, objective) -> "FallPace | None":
        """The pace with knee that a controller asks its falls with on objective: none where knee
        is 0 (the paper's constant delta) or the objective asks no fall (a DPL model's)."""
        if knee == 0 or not getattr(objective, "delta", 0) > 0:
            return None
        return cls(knee=knee)

    def start(self) -> "PaceState":
        """The state of one episode, f falling as asked so far."""
        return PaceState(self)


class PaceState:
    """One episode's pace: share(value) each tick gives the share of delta to ask."""

    def __init__(self, pace: FallPace):
        self.pace = pace
        self.previous: float | None = None
        self.asked_share = 1.0  # what the last tick asked, a share of delta
        self.realized = 1.0  # the averages, in units of delta
        self.asked = 1.0

    def share(self, value: float, delta: float) -> float:
        """The share of delta to ask this tick, given f's value now (f's units) and delta (f's
        units per tick); updates the averages with the fall since the last tick."""
        pace = self.pace
        if self.previous is not None:
            weight = 1.0 / pace.window_ticks
            self.realized += weight * ((self.previous - value) / delta - self.realized)
            self.asked += weight * (self.asked_share - self.asked)
        self.previous = value
        # the asked average is one of shares of at least floor, so never below it
        ratio = self.realized / self.asked
        self.asked_share = min(max(ratio / pace.knee, pace.floor), 1.0)
        return self.asked_share
