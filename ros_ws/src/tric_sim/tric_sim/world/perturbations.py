"""Perturbations of an episode (the paper's Sec. 5.4 stability claim put to the test): a push on the
arm, or a grasp target that jumps or moves, each scheduled at a simulated time after the scene's
reset. Plain data with the same fields as tric_msgs/Perturbation, carried by a situation
(tric_sim.world.situation) and applied by the physics (tric_sim.physics.simulation). Units: s, rad,
m.

A random start is not scheduled: it is a situation whose initial joint positions are drawn
(tric_sim.world.perturbation_trials.random_start).
"""

from dataclasses import dataclass

import numpy as np

from tric_sim.tools.untrusted import quoted

KINDS = ("push", "move_target")
#: The latest start and the longest duration a perturbation may have, s: far past any episode.
MAX_START_S = 600.0
MAX_DURATION_S = 600.0
#: The largest push, rad (norm of the joint offset), and the farthest target move, m: beyond these
#: a perturbation is not a disturbance but another task.
MAX_PUSH_RAD = 2.0
MAX_MOVE_M = 0.5
#: An episode runs at least this long after its last perturbation has acted, s: the rest rule's
#: window (tric_control.motion_rate), so that a controller at rest that the perturbation moved is
#: seen to leave rest, and one that stayed at rest is seen holding.
SETTLE_S = 0.5


@dataclass(frozen=True)
class Perturbation:
    """kind "push": the joints move by offset (n,) rad; "move_target": the grasp target moves by
    offset (3,) m (world frame). Either spread evenly over duration_s from start_s (s after the
    reset); duration 0 acts within one control period."""

    kind: str
    start_s: float
    offset: tuple
    duration_s: float = 0.0

    def validate(self, task: str, n_joints: int, where: str) -> "Perturbation":
        """self, or ValueError naming the problem; where: who carries it (for the message)."""
        if not isinstance(self.kind, str) or self.kind not in KINDS:
            raise ValueError(
                f"{where}: unknown perturbation kind '{quoted(self.kind, 40)}' "
                f"(known: {', '.join(KINDS)})"
            )
        for name, value, limit in (
            ("start_s", self.start_s, MAX_START_S),
            ("duration_s", self.duration_s, MAX_DURATION_S),
        ):
            if not (isinstance(value, (int, float)) and np.isfinite(value) and 0 <= value <= limit):
                raise ValueError(
                    f"{where}: a {self.kind}'s {name} must be in [0, {limit:g}] s, got "
                    f"{quoted(value, 40)}"
                )
        size = n_joints if self.kind == "push" else 3
        try:
            offset = np.asarray(self.offset, dtype=float)
        except (TypeError, ValueError, OverflowError):
            raise ValueError(
                f"{where}: a {self.kind}'s offset must be numbers, got {quoted(self.offset, 80)}"
            ) from None
        if offset.shape != (size,) or not np.all(np.isfinite(offset)):
            raise ValueError(
                f"{where}: a {self.kind}'s offset must be {size} finite numbers "
                f"({'rad, one per joint' if self.kind == 'push' else 'm, world x y z'}), "
                f"got {quoted(self.offset, 80)}"
            )
        if self.kind == "push" and np.linalg.norm(offset) > MAX_PUSH_RAD:
            raise ValueError(
                f"{where}: a push of {np.linalg.norm(offset):.3g} rad is over the "
                f"{MAX_PUSH_RAD:g} rad a push may be"
            )
        if self.kind == "move_target":
            if task != "grasp":
                raise ValueError(
                    f"{where}: a '{task}' task has no grasp target to move (the box stands on "
                    "the table); push the arm instead"
                )
            if np.linalg.norm(offset) > MAX_MOVE_M:
                raise ValueError(
                    f"{where}: a target move of {np.linalg.norm(offset):.3g} m is over the "
                    f"{MAX_MOVE_M:g} m a move may be"
                )
        return self

    def share(self, t0: float, t1: float) -> float:
        """The part of offset that acts between t0 and t1 (s after the reset; t0 < t1), in
        [0, 1]: the whole of it in the period holding start_s when duration_s is shorter than
        that period."""
        if self.duration_s <= t1 - t0:
            return 1.0 if t0 <= self.start_s < t1 else 0.0
        start, end = (np.clip((t - self.start_s) / self.duration_s, 0.0, 1.0) for t in (t0, t1))
        return float(end - start)

    def to_dict(self) -> dict:
        return {
            "kind": self.kind,
            "start_s": float(self.start_s),
            "offset": [float(v) for v in self.offset],
            "duration_s": float(self.duration_s),
        }

    @classmethod
    def from_dict(cls, data) -> "Perturbation":
        """From plain data (a situation file's entry); ValueError for unknown or missing keys.
        Validated by the situation that carries it."""
        keys = {"kind", "start_s", "offset", "duration_s"}
        if not isinstance(data, dict) or set(data) - keys or not {"kind", "start_s"} <= set(data):
            raise ValueError(
                f"bad perturbation entry {quoted(data, 80)} (expected the keys kind, start_s, "
                "offset and optionally duration_s)"
            )
        try:
            return cls(
                kind=data["kind"],
                start_s=float(data["start_s"]),
                offset=tuple(float(v) for v in data.get("offset", ())),
                duration_s=float(data.get("duration_s", 0.0)),
            )
        except (TypeError, ValueError, OverflowError):
            raise ValueError(
                f"bad perturbation entry {quoted(data, 80)}: not numbers, or too large"
            ) from None


def target_displacement(perturbations) -> np.ndarray:
    """The grasp target's displacement (3,) m once every move_target of perturbations has acted."""
    moves = [p.offset for p in perturbations if p.kind == "move_target"]
    return np.sum(moves, axis=0) if moves else np.zeros(3)


def min_steps_for(perturbations, period: float) -> int:
    """The control ticks an episode must run at least for all of perturbations to have acted and
    SETTLE_S more (0 for none): a controller that came to rest before them is still there, holding,
    when they come, and what they did shows before the episode ends (tric_control.episode_runner's
    min_steps). period: the control period, s."""
    end = max((p.start_s + p.duration_s for p in perturbations), default=0.0)
    return int(np.ceil((end + SETTLE_S) / period)) + 1 if perturbations else 0
