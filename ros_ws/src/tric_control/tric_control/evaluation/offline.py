"""Offline evaluation: the controller core on PhysicsWorld, no nodes. ROS-free.

The same episodes as through the nodes (tric_control.evaluation.graph), without the graph: the scene
is reset to the situation, the model's controller is run by the same EpisodeRunner as the controller
node's, each command goes to the physics as the simulator would apply it, and the final state is
judged by the same hidden metrics (with the lift test for grasps). The teacher runs its core
(tric_sim.teachers.demonstrate) the same way. Sweeps and method studies use this; the results'
tables come from the nodes.

An episode through the nodes and offline differ only in the lockstep protocol's timing (the
simulator steps on its own when a command is late), so the two agree to within the physics'
run-to-run spread.
"""

import pathlib
import time

from tqdm import tqdm

from tric_control.episode_runner import DEFAULT_MAX_STEPS, EpisodeRunner
from tric_control.evaluation.executors import ProcessExecutor
from tric_control.evaluation.records import EpisodeRecord, evaluated_task, unjudged_fields
from tric_control.evaluation.shipped_files import local_path
from tric_control.fall_pace import FallPace
from tric_control.motion_rate import MotionRateController
from tric_control.objectives import CONTROL_PERIOD, make_objective
from tric_control.stall_escape import DEFAULT_ESCAPES, StallEscape
from tric_learning.features import FeatureDefinition
from tric_learning.model_file import ModelFile
from tric_sim import teachers
from tric_sim.physics import metrics
from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.world.durations import DEFAULT_DURATION
from tric_sim.world.perturbations import min_steps_for
from tric_sim.world.proximity import Proximity
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.robot_profile import DEFAULT_ROBOT
from tric_sim.world.scene import task_grip


class OfflineEvaluator:
    """A physics world and, unless model is None (the teacher), a loaded model for one task.

    Args:
        task: "grasp" or "open_box".
        model: a model file path, or None for the teacher.
        max_steps: control ticks per episode at most (0: the task's DEFAULT_MAX_STEPS, as the
            controller node's).
        period: the control period, s.
        controller_options: keyword arguments of MotionRateController (e.g. max_lead), for studies,
            "rho_scale": make_objective's, "grip": False leaves out the task's grip once at
            rest (tric_sim.world.scene.task_grip), and "fall_pace_knee": the knee of the asked
            fall's pace (tric_control.fall_pace.FallPace; default its knee, as the controller
            node's parameter; 0: the paper's constant delta; none for a model that asks no fall),
            "stall_escapes": the walks out of stalls an episode may take
            (tric_control.stall_escape.StallEscape; default DEFAULT_ESCAPES, as the controller
            node's; 0: none).
        lift_test: whether a grasp is judged with the lift test (False: its success is the grasp
            cost's alone and lift_passed is None; the final state is the same either way).
        robot: the robot, a profile's name or file (docs/robots.md); a model made for another
            is refused.
    """

    def __init__(
        self,
        task: str,
        model=None,
        max_steps: int = 0,
        period: float = CONTROL_PERIOD,
        controller_options: dict | None = None,
        lift_test: bool = True,
        robot: str = DEFAULT_ROBOT,
    ):
        self.task, self.model, self.period = task, model, period
        self.lift_test = lift_test
        self.controller_options = dict(controller_options or {})
        rho_scale = self.controller_options.pop("rho_scale", 1.0)
        self.max_steps = max_steps or DEFAULT_MAX_STEPS[task]
        self.robot = RobotModel(robot)
        gripping = self.controller_options.pop("grip", True)
        knee = self.controller_options.pop("fall_pace_knee", FallPace.knee)
        escapes = self.controller_options.pop("stall_escapes", DEFAULT_ESCAPES)
        self.escape = StallEscape(escapes)
        self.grip = task_grip(task, self.robot.profile) if gripping else None
        self.objective = None
        self.kind: str = "teacher"
        self.objects = ()
        if model is not None:
            model_file = ModelFile.load(model, FeatureDefinition.for_task(task, self.robot))
            self.objective = make_objective(model_file, self.robot, period, rho_scale)
            self.kind = model_file.kind
            self.objects = tuple(
                source.partition("/")[2]
                for source in model_file.definition.landmark_sources
                if source.startswith("object/")
            )
            self.controller_options["fall_pace"] = FallPace.for_objective(knee, self.objective)
        self.world = PhysicsWorld(self.robot, control_rate_hz=1.0 / period)

    @property
    def agent(self) -> str:
        return self.kind

    def close(self) -> None:
        self.world.close()

    def run(self, situation, snapshot: pathlib.Path | None = None, on_period=None) -> EpisodeRecord:
        """One episode of the agent on situation, judged by the hidden metrics. on_period(world,
        step): after each control period a model's controller stepped (step: episode.Step), or
        the teacher's (step None)."""
        if situation.task != self.task:
            raise ValueError(
                f"situation '{situation.name}' is a '{situation.task}' task, not '{self.task}'"
            )
        started = time.monotonic()
        world, grasp = self.world, situation.task == "grasp"
        record = unjudged_fields(situation, self.agent)
        if self.model is None:
            duration = DEFAULT_DURATION[situation.task]
            teachers.demonstrate(
                world,
                self.robot,
                situation,
                duration,
                on_period=None if on_period is None else lambda *_: on_period(world, None),
            )
            steps, outcome = int(round(duration / world.control_period)), "demonstrated"
            if snapshot is not None:
                self._snapshot(snapshot, situation)
        else:
            world.reset(situation)
            controller = MotionRateController(
                self.robot,
                Proximity(self.robot, situation),
                self.objective,
                self.period,
                **self.controller_options,
            )
            runner = EpisodeRunner(
                self.robot,
                controller,
                self.max_steps,
                self.period,
                self.objects,
                grip=self.grip,
                min_steps=min_steps_for(situation.perturbations, self.period),
                escape=self.escape,
            )
            ended = None  # (outcome, message) once the runner ends the episode
            try:
                while ended is None:
                    q, _ = world.joint_state()
                    decided = runner.step(q, world.object_poses())
                    world.command(decided.command)
                    world.step()
                    if on_period is not None:
                        on_period(world, decided)
                    ended = decided.outcome
            except RuntimeError as error:
                record["steps"] = runner.stats.steps
                return EpisodeRecord(
                    **record,
                    wall_time_s=time.monotonic() - started,
                    outcome="failed",
                    message=str(error),
                )
            steps, outcome = runner.stats.steps, ended[0]
            record["min_joint_margin"] = runner.stats.min_joint_margin
            if snapshot is not None:
                self._snapshot(snapshot, situation)
        judged = metrics.evaluate(world, self.robot, run_lift_test=grasp and self.lift_test)
        record.update(
            success=bool(judged.success),
            min_distance=judged.min_distance,
            collided=bool(judged.collided),
            steps=int(steps),
        )
        if grasp:
            lifted = bool(judged.lift_passed) if judged.lift_tested else None
            record.update(grasp_cost=judged.grasp_cost, lift_passed=lifted)
        else:
            record["lid_angle"] = judged.lid_angle
        return EpisodeRecord(
            **record,
            wall_time_s=time.monotonic() - started,
            outcome=outcome,
            max_joint_overshoot=judged.max_joint_overshoot,
            failure=judged.failure,
        )

    def _snapshot(self, folder: pathlib.Path, situation) -> None:
        from tric_sim.viz.situation_pictures import write_png

        folder.mkdir(parents=True, exist_ok=True)
        write_png(folder / f"{situation.name}.png", self.world.render(480, 360))


def evaluate_offline(
    situations,
    model=None,
    max_steps: int = 0,
    snapshots=None,
    progress=True,
    desc="evaluating offline",
    jobs: int = 1,
    controller_options: dict | None = None,
    on_record=None,
    executor=None,
    robot: str = DEFAULT_ROBOT,
) -> list:
    """Run the agent (a model file, or the teacher if None) on every situation offline, on robot
    (a profile's name or file);
    [EpisodeRecord] in the situations' order; on_record(record) (if given) as each episode ends.
    jobs > 1, or a Ray executor: that many workers of executor (tric_control.evaluation.executors;
    None: spawned processes here), each with its own world. controller_options: see
    OfflineEvaluator."""
    task = evaluated_task(situations, jobs)
    snapshot = pathlib.Path(snapshots) if snapshots else None
    jobs = min(jobs, len(situations))
    records: list[EpisodeRecord | None] = [None] * len(situations)
    with tqdm(total=len(situations), desc=desc, unit="episode", disable=not progress) as bar:
        if jobs <= 1 and getattr(executor, "kind", "processes") == "processes":
            evaluator = OfflineEvaluator(
                task, model, max_steps, controller_options=controller_options, robot=robot
            )
            try:
                for k, situation in enumerate(situations):
                    bar.set_postfix_str(situation.name)
                    records[k] = evaluator.run(situation, snapshot)
                    bar.update()
                    if on_record is not None:
                        on_record(records[k])
            finally:
                evaluator.close()
            return records
        executor = executor or ProcessExecutor()
        arguments = (task, executor.ship(model), max_steps, controller_options, robot)
        return executor.run_episodes(
            situations,
            snapshot,
            jobs,
            bar,
            _worker_evaluator,
            lambda: arguments,
            "teacher" if model is None else "model",
            on_record,
        )


def _worker_evaluator(
    _worker, task, model, max_steps, controller_options, robot
) -> OfflineEvaluator:
    """A worker's OfflineEvaluator (see tric_control.evaluation.executors); every worker alike."""
    return OfflineEvaluator(
        task, local_path(model), max_steps, controller_options=controller_options, robot=robot
    )
