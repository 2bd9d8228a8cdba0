"""The controller node's parameters (docs: the node's module and the package README), declared and
checked in one place, and the controller settings they make."""

from dataclasses import dataclass

from tric_control.episode_runner import DEFAULT_MAX_STEPS
from tric_control.fall_pace import FallPace
from tric_control.stall_escape import DEFAULT_ESCAPES, StallEscape
from tric_learning.features import TASKS
from tric_sim.ros.parameters import AT_LEAST_ONE, NOT_NEGATIVE, POSITIVE, Range, declare

MODES = ("lockstep", "realtime")
#: The parameters that make the paper's controller (Sec. 5.2.3 and 5.4): a constant delta, no pace,
#: and a rest at any minimum of f (no stall escape).
PAPER_CONTROLLER = {"fall_pace_knee": 0.0, "stall_escapes": 0}


@dataclass(frozen=True)
class ControllerParameters:
    """The node's checked parameters: task, model_path, mode, control_rate_hz (Hz), max_steps
    (ticks), state_timeout_s (wall s), fall_pace_knee (the knee of the asked fall's pace, in
    [0, 1]; 0: the paper's constant delta) and stall_escapes (the walks out of stalls an episode
    may take, >= 0; 0: none, the paper's controller)."""

    task: str
    model_path: str
    mode: str
    control_rate_hz: float
    max_steps: int
    state_timeout_s: float
    fall_pace_knee: float
    stall_escapes: int

    def fall_pace(self, objective) -> FallPace | None:
        """The pace the controller asks its falls with on objective (FallPace.for_objective)."""
        return FallPace.for_objective(self.fall_pace_knee, objective)

    def escape(self) -> StallEscape:
        """How an episode's controller leaves stalls (tric_control.stall_escape)."""
        return StallEscape(self.stall_escapes)


def declare_parameters(node) -> ControllerParameters:
    """Declares the controller's parameters on node; ValueError for a bad value."""
    task = declare(node, "task", "grasp", "the task models must match", TASKS)
    return ControllerParameters(
        task=task,
        model_path=declare(node, "model_path", "", "a model file to load at start (empty: none)"),
        mode=declare(
            node, "mode", "lockstep", "answer every joint state, or tick on a timer", MODES
        ),
        control_rate_hz=declare(
            node, "control_rate_hz", 100.0, "control ticks per second", Range(1.0, 1000.0)
        ),
        max_steps=declare(
            node,
            "max_steps",
            DEFAULT_MAX_STEPS[task],
            "an episode's default step budget",
            AT_LEAST_ONE,
        ),
        state_timeout_s=declare(
            node,
            "state_timeout_s",
            10.0,
            "wall seconds without joint states before an episode aborts",
            POSITIVE,
        ),
        fall_pace_knee=declare(
            node,
            "fall_pace_knee",
            FallPace.knee,
            "the asked fall follows the fall f makes below this share of it (0: the paper's "
            "constant delta)",
            Range(0.0, 1.0),
        ),
        stall_escapes=declare(
            node,
            "stall_escapes",
            DEFAULT_ESCAPES,
            "random walks out of a rest far above where the model's rollouts rested (0: none)",
            NOT_NEGATIVE,
        ),
    )
