"""Perturbed copies of situations, drawn reproducibly: the trials of Exp. 5
(tric_control.experiments.exp5) and of `tric-eval --perturb`.

A trial is a kind and a size:
    push:SIZE     the arm is shoved by SIZE rad (norm over the arm's joints) in PUSH_DURATION_S
    jolt:SIZE     the same shove within one control period: faster than the joint servos take it
                  back, so it moves an arm that the controller holds at rest (a push over
                  PUSH_DURATION_S does not: docs/decisions/perturbations.md)
    jump:SIZE     the grasp target jumps SIZE m sideways (horizontal)
    drift:SIZE    the grasp target moves sideways at SIZE m/s for DRIFT_DURATION_S
    start:SIZE    the episode starts SIZE rad (norm over the arm's joints) from its nominal start,
                  collision-free and within the joint limits
optionally "@SECONDS", the simulated time after the reset at which it acts (default: the task's
PERTURB_AT_S). The direction is drawn from the situation's name and seed and the kind, not the size:
the trials of one situation grow along one direction.
"""

import dataclasses
import zlib
from typing import Any

import numpy as np

from tric_sim.world.perturbations import Perturbation
from tric_sim.world.scene_check import check_scene
from tric_sim.world.situation import Situation

KINDS = ("push", "jump", "drift", "start", "jolt")
#: A push acts over this long, s (an impulse on a position-controlled arm).
PUSH_DURATION_S = 0.1
#: A drifting target moves for this long, s.
DRIFT_DURATION_S = 3.0
#: When a perturbation acts by default, s after the reset: a grasp mid-approach (the teacher's
#: grasps close at about 3 s of 5); a box with the finger under the lip, just before the lid lifts
#: (measured on training and validation boxes: the box teacher's lid passes 0.02 rad at 4.21 to
#: 4.26 s of its 8 s demonstrations on box_train_00, 03, 07 and box_val_03, 10).
PERTURB_AT_S = {"grasp": 1.0, "open_box": 4.0}
#: Draws of a random start before it is refused (each must be collision-free within the limits).
START_DRAWS = 200


@dataclasses.dataclass(frozen=True)
class Trial:
    """One perturbation of a situation: kind (KINDS), size (rad, m or m/s, see the module), at_s
    (None: the task's PERTURB_AT_S)."""

    kind: str
    size: float
    at_s: float | None = None

    @property
    def label(self) -> str:
        """The trial's part of a perturbed situation's name, e.g. "push0.2" or "jump0.05@1.5"."""
        return f"{self.kind}{self.size:g}" + ("" if self.at_s is None else f"@{self.at_s:g}")

    def apply(self, situation: Situation, robot) -> Situation:
        """A copy of situation named "<name>_<label>" with this trial's perturbation (or, for
        "start", its drawn initial joint positions); ValueError if it cannot be (a move for a box,
        no collision-free start). robot: tric_sim.world.robot_model.RobotModel."""
        name = f"{situation.name}_{self.label}"
        at_s = PERTURB_AT_S[situation.task] if self.at_s is None else self.at_s
        rng = np.random.default_rng(
            [zlib.crc32(situation.name.encode()), situation.seed, KINDS.index(self.kind)]
        )
        changed: dict[str, Any] = {"name": name}
        if self.kind in ("push", "start", "jolt"):
            direction = np.zeros(robot.n_joints)
            arm = rng.standard_normal(len(robot.arm_indices))
            direction[robot.arm_indices] = arm / np.linalg.norm(arm)
        else:
            angle = rng.uniform(0.0, 2 * np.pi)
            direction = np.array([np.cos(angle), np.sin(angle), 0.0])
        if self.size == 0:
            pass
        elif self.kind in ("push", "jolt"):
            duration = PUSH_DURATION_S if self.kind == "push" else 0.0
            changed["perturbations"] = situation.perturbations + (
                Perturbation("push", at_s, _floats(self.size * direction), duration),
            )
        elif self.kind == "jump":
            changed["perturbations"] = situation.perturbations + (
                Perturbation("move_target", at_s, _floats(self.size * direction)),
            )
        elif self.kind == "drift":
            changed["perturbations"] = situation.perturbations + (
                Perturbation(
                    "move_target",
                    at_s,
                    _floats(self.size * DRIFT_DURATION_S * direction),
                    DRIFT_DURATION_S,
                ),
            )
        else:
            changed["initial_joint_positions"] = _random_start(situation, self.size, rng, robot)
        perturbed = dataclasses.replace(situation, **changed)
        return check_scene(perturbed.validate(robot.n_joints), robot)


def parse_trial(text: str) -> Trial:
    """The Trial of "KIND:SIZE[@SECONDS]" (see the module), or ValueError saying what is wrong."""
    kind, _, rest = str(text).partition(":")
    size_text, _, at_text = rest.partition("@")
    if kind not in KINDS or not size_text:
        raise ValueError(
            f"perturbation '{text}' is not KIND:SIZE[@SECONDS] with KIND one of {', '.join(KINDS)} "
            "(e.g. push:0.2, jump:0.05@1.5, drift:0.02, start:0.3, jolt:0.4@7.5)"
        )
    try:
        size = float(size_text)
        at_s = float(at_text) if at_text else None
    except ValueError:
        raise ValueError(f"perturbation '{text}': SIZE and SECONDS must be numbers") from None
    if not (np.isfinite(size) and size >= 0) or (at_s is not None and not np.isfinite(at_s)):
        raise ValueError(f"perturbation '{text}': SIZE must be >= 0 and SECONDS finite")
    return Trial(kind, size, at_s)


def _random_start(situation: Situation, radius: float, rng, robot) -> tuple:
    """Initial joint positions radius rad (norm over the arm's joints) from the situation's start,
    in a direction drawn by rng: the first draw within the joint limits and collision-free."""
    nominal = np.asarray(situation.initial_joint_positions or robot.home, dtype=float)
    problem = "every draw left the joint limits"
    for _ in range(START_DRAWS):
        arm = rng.standard_normal(len(robot.arm_indices))
        q = nominal.copy()
        q[robot.arm_indices] += radius * arm / np.linalg.norm(arm)
        if np.any(q < robot.lower) or np.any(q > robot.upper):
            continue
        try:
            check_scene(dataclasses.replace(situation, initial_joint_positions=tuple(q)), robot)
        except ValueError as error:
            problem = str(error)
            continue
        return tuple(float(v) for v in q)
    raise ValueError(
        f"situation '{situation.name}': no start {radius:g} rad from its own in {START_DRAWS} "
        f"draws (the last problem: {problem})"
    )


def _floats(values) -> tuple:
    return tuple(float(v) for v in values)
