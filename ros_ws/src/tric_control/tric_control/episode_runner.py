"""One controller episode, tick by tick, without ROS: measured state in, safe command out. ROS-free.

EpisodeRunner is the loop that every way of running a model shares: the controller node (lockstep or
realtime, tric_control.controller_node) and the offline evaluation on PhysicsWorld
(tric_control.evaluation.offline). Each control period it is handed the measured joint positions q
(n,), rad, and the objects' poses, and returns the command to send:

- a fresh, complete state: one motion-rate step (tric_control.motion_rate), made safe: the target is
  moved into the joint limits and within one period's velocity bound of the previous command (the
  controller respects both already; a violation is clipped, counted and reported);
- a stale state (older than STALE_PERIODS control periods) or missing object poses: a hold, the last
  measured positions approached within the velocity bound; the controller is not stepped;
- a rest that is a stall (tric_control.stall_escape: f far above where the model's own rollouts
  came to rest), with walks left to the episode's StallEscape: a random walk of the arm through
  the same controller, then the descent again;
- once the controller comes to rest (its model's rest rule), the task's grip, if it has one
  (tric_sim.world.scene.task_grip: a grasp closes the fingers by the teacher's squeeze past where
  they rest), is ramped in over its duration without stepping the controller, and the episode
  ends "converged"; an episode asked to run min_steps at least holds the robot there until then,
  and steps the controller again when the arm is moved away (a push); the episode ends
  "step_budget" when the budget is spent first (the grip's ticks count in it).

It also keeps the episode's statistics (values of the objective, closest approach, joint-limit
margin, tick times). Units: rad, m, s; stamps in ns.
"""

import math
import time
from dataclasses import dataclass, field
from typing import cast

import numpy as np

from tric_control.motion_rate import MotionRateController, Tick
from tric_control.stall_escape import WALK_TICKS, StallEscape, WalkObjective, stalled
from tric_sim.world.robot_model import RobotModel

#: A state older than this many control periods is stale: the runner holds instead of stepping.
STALE_PERIODS = 3
#: An episode's step budget when none is given, by task, ticks at 100 Hz: 12 s for a grasp (the
#: paper's take 5 s; time for a cylinder grasp's fingers to settle, come to rest and grip:
#: docs/decisions/rest-and-grip.md), 20 s for a box (its demonstrations last 8 s;
#: docs/decisions/loss-balance.md).
DEFAULT_MAX_STEPS = {"grasp": 1200, "open_box": 2000}
#: At rest, the arm moved farther than this from where it rested (rad, norm over the arm's joints:
#: a push) takes the controller out of rest (EpisodeRunner's min_steps).
LEAVE_REST_RAD = 0.05
#: The paper's protocol (Sec. 5.2.3): delta makes about 500 ticks from a demonstration's start to
#: its end, and a grasp is judged after 500 steps of 10 ms (tric-eval --protocol paper).
PAPER_STEPS = 500


@dataclass
class EpisodeStats:
    """Running statistics of an episode. Values of the controller's objective (f for TRIC), the
    smallest collision distance the controller saw (m), the smallest distance of a measured joint to
    its limit (rad), each tick's computing time (ms), safety clips, the tick at which the
    controller last came to rest (None: it has not), how often it left rest, moved, and how many
    random walks it took out of stalls."""

    steps: int = 0
    holds: int = 0
    initial_value: float = math.nan
    final_value: float = math.nan
    min_distance: float = math.inf
    min_joint_margin: float = math.inf
    tick_ms: list = field(default_factory=list)
    violations: int = 0
    rest_step: int | None = None
    rests_left: int = 0
    walks: int = 0

    @property
    def mean_tick_ms(self) -> float:
        return float(np.mean(self.tick_ms)) if self.tick_ms else math.nan

    @property
    def max_tick_ms(self) -> float:
        return float(np.max(self.tick_ms)) if self.tick_ms else math.nan


@dataclass
class Step:
    """What the runner decided for one state: the command (n,) to send; the controller's tick (None
    when holding or gripping); why it held ("" when it stepped); the command's distance from the
    previous one, rad; the tick's computing time, ms; whether the task's grip is closing; and
    (outcome, message) when the episode is over, else None."""

    command: np.ndarray
    tick: Tick | None = None
    held: str = ""
    step_norm: float = 0.0
    tick_ms: float = 0.0
    gripping: bool = False
    outcome: tuple | None = None


class EpisodeRunner:
    """Drives one episode of a motion-rate controller (see the module docstring).

    Args:
        robot: the kinematic model (joint limits, velocity limits).
        controller: the controller to step, reset by the runner at the first state.
        max_steps: the step budget, ticks (>= 1).
        period: the control period, s.
        required_objects: names whose poses each tick needs (the model's landmarks).
        on_violation: called with a description each time a command had to be clipped.
        grip: the task's grip once at rest (tric_sim.world.scene.Grip), or None.
        min_steps: the episode ends at rest only from this tick on (an evaluation that perturbs the
            world after the controller may have come to rest asks for it); until then the runner
            holds the robot at rest (gripped), and when something moves the arm more than
            LEAVE_REST_RAD from where it rested, the controller steps again from there.
        escape: how the controller leaves stalls (tric_control.stall_escape.StallEscape); None:
            it does not (a stall is a rest, as the paper's controller has it).
    """

    def __init__(
        self,
        robot: RobotModel,
        controller: MotionRateController,
        max_steps: int,
        period: float,
        required_objects=(),
        on_violation=None,
        grip=None,
        min_steps: int = 0,
        escape: StallEscape | None = None,
    ):
        if max_steps < 1:
            raise ValueError(f"the step budget must be at least 1 tick, got {max_steps}")
        if not (math.isfinite(period) and period > 0):
            raise ValueError(f"the control period must be finite and positive, got {period!r}")
        self.robot, self.controller, self.max_steps, self.period = (
            robot,
            controller,
            max_steps,
            period,
        )
        self.period_ns = int(round(period * 1e9))
        self.required_objects = tuple(required_objects)
        self.on_violation = on_violation or (lambda _: None)
        self.max_step = robot.velocity_limits * period
        self.stats = EpisodeStats()
        # the last command sent (n,), None before the first state
        self.previous: np.ndarray | None = None
        self.grip = grip
        self.min_steps = min_steps
        self._grip_joints = (
            np.array([robot.joint_names.index(j) for j in grip.joints]) if grip else None
        )
        self._grip_ticks = int(math.ceil(grip.duration_s / period)) if grip else 0
        # once at rest: the command the grip closes from, and the measured joints there
        self._rest_command: np.ndarray | None = None
        self._rest_q: np.ndarray | None = None
        self.escape = escape or StallEscape()
        # the walk out of a stall under way (None: descending) and its ticks so far
        self._walk: WalkObjective | None = None
        self._walk_ticks = 0

    @property
    def started(self) -> bool:
        return self.previous is not None

    def missing(self, object_poses: dict) -> list:
        """The required objects that object_poses lacks."""
        return [name for name in self.required_objects if name not in object_poses]

    def step(
        self, q, object_poses: dict, stamp_ns: int | None = None, now_ns: int | None = None
    ) -> Step:
        """The command for the measured state q (n,) stamped stamp_ns, at time now_ns (both None:
        never stale). Raises ValueError for a q of the wrong size or with NaN/inf, RuntimeError when
        the controller fails on this input."""
        q = np.asarray(q, dtype=float)
        if q.shape != (self.robot.n_joints,) or not np.all(np.isfinite(q)):
            raise ValueError(
                f"the measured state must be {self.robot.n_joints} finite joint positions"
            )
        if self.previous is None:
            self.previous = q.copy()
            self.controller.reset(q)
        stale = (
            stamp_ns is not None
            and now_ns is not None
            and now_ns - stamp_ns > STALE_PERIODS * self.period_ns
        )
        missing = self.missing(object_poses)
        if stale or missing:
            return self.hold(
                q, "stale joint states" if stale else f"no pose of {', '.join(missing)}"
            )
        if self._rest_command is not None:
            moved = (
                q[self.robot.arm_indices] - cast(np.ndarray, self._rest_q)[self.robot.arm_indices]
            )
            if np.linalg.norm(moved) <= LEAVE_REST_RAD:
                return self._at_rest()
            # moved from where it rested (pushed): the controller steps again from here
            self._rest_command = self._rest_q = None
            self.stats.rests_left += 1
            self.controller.reset(q)
        started = time.perf_counter()
        try:
            tick = self.controller.tick(q, object_poses)
        except Exception as error:  # the objective or the QP failed on this input
            raise RuntimeError(
                f"control tick {self.stats.steps} failed: {type(error).__name__}: {error}"
            ) from None
        tick_ms = (time.perf_counter() - started) * 1e3
        command = self.safe_command(tick.target)
        if not np.array_equal(command, tick.target):
            self.controller.reference = command.copy()  # integrate from what is actually commanded
        step_norm = float(np.linalg.norm(command - self.previous))
        self.previous = command
        stats = self.stats
        stats.steps += 1
        if stats.steps == 1:
            stats.initial_value = float(tick.value)
        stats.final_value = float(tick.value)
        stats.min_distance = min(stats.min_distance, float(tick.min_distance))
        margin = float(min(np.min(q - self.robot.lower), np.min(self.robot.upper - q)))
        stats.min_joint_margin = min(stats.min_joint_margin, margin)
        stats.tick_ms.append(tick_ms)
        outcome = None
        if self._walk is not None:
            self._walk_ticks += 1
            if self._walk.reached(q) or self._walk_ticks >= WALK_TICKS:
                self._end_walk(q)
        elif tick.converged and self._escapes(tick.value):
            self._begin_walk(q)
        elif tick.converged:
            stats.rest_step = stats.steps
            if self.grip is None and stats.steps >= self.min_steps:
                outcome = ("converged", f"converged after {stats.steps} steps")
            else:
                self._rest_command, self._rest_q = command.copy(), q.copy()
        if outcome is None and stats.steps >= self.max_steps:
            outcome = ("step_budget", f"step budget of {self.max_steps} spent")
        return Step(
            command=command, tick=tick, step_norm=step_norm, tick_ms=tick_ms, outcome=outcome
        )

    def _escapes(self, value: float) -> bool:
        """Whether a rest with f at value is a stall to walk out of (walks left)."""
        return self.stats.walks < self.escape.escapes and stalled(self.controller.objective, value)

    def _begin_walk(self, q: np.ndarray) -> None:
        """The controller follows a walk from q to the escape's next goal, without a pace."""
        robot, controller = self.robot, self.controller
        goal = self.escape.goal(q, robot.arm_indices, robot.lower, robot.upper, self.stats.walks)
        self.stats.walks += 1
        self._walk = WalkObjective(controller.objective, goal, self.max_step)
        self._walk_ticks = 0
        controller.objective = self._walk
        controller.reset(cast(np.ndarray, self.previous), paced=False)

    def _end_walk(self, q: np.ndarray) -> None:
        """The walk is over at q: the controller descends f again from there."""
        self.controller.objective = cast(WalkObjective, self._walk).inner
        self._walk = None
        self.controller.reset(q)

    def _at_rest(self) -> Step:
        """One tick at rest, the controller not stepped: the grip's joints' commands a share more
        of the squeeze past where they came to rest (within their limits and the velocity bound),
        then held; the episode ends once the squeeze is in and min_steps are done, or the budget
        is spent."""
        stats = self.stats
        stats.steps += 1
        done = stats.steps - cast(int, stats.rest_step)
        target = cast(np.ndarray, self._rest_command).copy()
        closing = self.grip is not None and done <= self._grip_ticks
        if self.grip is not None:
            joints = cast(np.ndarray, self._grip_joints)
            squeeze = self.grip.squeeze * min(done / self._grip_ticks, 1.0)
            target[joints] = self.robot.closed(target[joints], joints, squeeze)
        command = self.safe_command(np.minimum(target, self.robot.upper), count=False)
        self.controller.reference = command.copy()
        step_norm = float(np.linalg.norm(command - cast(np.ndarray, self.previous)))
        self.previous = command
        outcome = None
        if done >= self._grip_ticks and stats.steps >= self.min_steps:
            grip = f", then gripped for {self._grip_ticks}" if self.grip is not None else ""
            outcome = ("converged", f"at rest after {stats.rest_step} steps{grip}")
        elif stats.steps >= self.max_steps:
            outcome = ("step_budget", f"step budget of {self.max_steps} spent at rest")
        return Step(command=command, step_norm=step_norm, gripping=closing, outcome=outcome)

    def hold(self, q, reason: str) -> Step:
        """Command the measured positions q (approached within the velocity bound), without stepping
        the controller."""
        q = np.asarray(q, dtype=float)
        if self.previous is None:
            self.previous = q.copy()
            self.controller.reset(q)
        command = self.safe_command(q, count=False)
        if self.controller.reference is not None:
            self.controller.reference = command.copy()
        step_norm = float(np.linalg.norm(command - self.previous))
        self.previous = command
        self.stats.holds += 1
        return Step(command=command, held=reason, step_norm=step_norm)

    def safe_command(self, target, count: bool = True) -> np.ndarray:
        """target moved into the joint limits and within one tick's velocity bound of the previous
        command; a non-finite or mis-sized target holds the previous command. Violations are counted
        and reported (on_violation) if count."""
        target = np.asarray(target, dtype=float)
        previous = cast(np.ndarray, self.previous)  # step and hold set it first
        if target.shape != previous.shape or not np.all(np.isfinite(target)):
            self._violation("a non-finite or mis-sized target; holding the previous command")
            return previous.copy()
        change = target - previous
        command = np.clip(
            previous + np.clip(change, -self.max_step, self.max_step),
            self.robot.lower,
            self.robot.upper,
        )
        if count and np.any(np.abs(change) > self.max_step + 1e-12):
            self._violation("a target step beyond the velocity bound")
        if count and np.any((target < self.robot.lower) | (target > self.robot.upper)):
            self._violation("a target outside the joint limits")
        return command

    def _violation(self, what: str) -> None:
        self.stats.violations += 1
        self.on_violation(
            f"clipped {what} ({self.stats.violations} safety violations in this episode)"
        )
