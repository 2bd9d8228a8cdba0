"""Evaluation episodes through the real nodes: the simulator (lockstep), the teacher, the
controller and (to record) the recorder in one in-process graph on a DDS domain of its own. For
each situation: reset the scene, let the teacher demonstrate it or the controller run the loaded
model for one episode, then judge the final state with the hidden metrics (with the lift test for
grasps). evaluate() runs several such graphs at once, each in a spawned worker process."""

import multiprocessing.util
import os
import pathlib
import time

import numpy as np
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.parameter import Parameter
from tqdm import tqdm

from tric_control.controller_node import ControllerNode
from tric_control.evaluation.executors import ProcessExecutor
from tric_control.evaluation.records import EpisodeRecord, evaluated_task, unjudged_fields
from tric_control.evaluation.shipped_files import local_path
from tric_control.objectives import CONTROL_PERIOD, RUNNABLE_KINDS
from tric_learning.recorder_node import RecorderNode
from tric_msgs.action import Demonstrate, Execute
from tric_msgs.msg import EpisodeEvent
from tric_msgs.srv import EvaluateTask, LoadModel, RenderScene, ResetScene
from tric_sim.ros import messages
from tric_sim.ros.dds_domains import MAX_DOMAIN_ID
from tric_sim.ros.fields import check_integer
from tric_sim.ros.graph import EVENT_QOS, InProcessGraph, wait
from tric_sim.simulator_node import lockstep_simulator
from tric_sim.teacher_node import TeacherNode
from tric_sim.visualizer_node import VisualizerNode
from tric_sim.viz.situation_pictures import write_png
from tric_sim.world.perturbations import min_steps_for
from tric_sim.world.robot_profile import DEFAULT_ROBOT

#: Wall seconds to wait for a service answer, for an episode to end, and for the recorder to close
#: an episode's bag (--record).
SERVICE_TIMEOUT, EPISODE_TIMEOUT, BAG_TIMEOUT = 60.0, 900.0, 30.0


class Evaluator:
    """The evaluation graph: simulator, teacher, controller and a client node, spun in-process.

    model: a model file for the controller, or None to evaluate the teacher; domain_id: the DDS
    domain of the graph (None: the environment's); view: a FoxgloveView to show the episodes in
    (None: no visualizer); record: a folder for one bag per episode (None: no recorder); robot: the
    robot, a profile's name or file (docs/robots.md), a parameter of every node; controller: the
    controller node's other parameters by name (e.g. {"fall_pace_knee": 0.0}; None: its
    defaults)."""

    def __init__(
        self,
        task: str,
        model: str = None,
        max_steps: int = 0,
        domain_id: int = None,
        view=None,
        record=None,
        robot: str = DEFAULT_ROBOT,
        controller: dict | None = None,
    ):
        self.task, self.model = task, model
        robot_parameter = Parameter("robot", value=robot)
        self.max_steps = check_integer(max_steps, "uint32", "max_steps")  # the Execute goal's
        self.graph = InProcessGraph(domain_id)
        self.closed = False
        self.recorder = None
        try:
            self.simulator = self.graph.add(lockstep_simulator(self.graph.context, robot))
            if view is not None:
                self.graph.add(
                    VisualizerNode(
                        view=view,
                        context=self.graph.context,
                        parameter_overrides=[robot_parameter],
                    )
                )
            if record is not None:
                self.recorder = self.graph.add(
                    RecorderNode(
                        context=self.graph.context,
                        parameter_overrides=[
                            Parameter("output_dir", value=str(record)),
                            Parameter(
                                "sources",
                                value=["teacher"] if model is None else list(RUNNABLE_KINDS),
                            ),
                            Parameter(
                                "status_topic", value="" if model is None else "/controller/status"
                            ),
                            robot_parameter,
                        ],
                    )
                )
            if model is None:
                self.graph.add(
                    TeacherNode(context=self.graph.context, parameter_overrides=[robot_parameter])
                )
            else:
                self.controller = self.graph.add(
                    ControllerNode(
                        context=self.graph.context,
                        parameter_overrides=[
                            Parameter("task", value=task),
                            Parameter("mode", value="lockstep"),
                            robot_parameter,
                            *(Parameter(k, value=v) for k, v in (controller or {}).items()),
                        ],
                    )
                )
            self.client = self.graph.add(Node("tric_eval", context=self.graph.context))
            if model is not None:
                # each controller episode's END stamp: the metrics wait for the simulator to have
                # applied the command that answered it; with --record, the evaluator publishes the
                # episode's OUTCOME stamped so
                self._end_stamps = {}
                self.client.create_subscription(
                    EpisodeEvent, "/episode", self._on_episode_event, EVENT_QOS
                )
            if self.recorder is not None and model is not None:
                self.outcome_pub = self.client.create_publisher(EpisodeEvent, "/episode", EVENT_QOS)
            self.graph.start()
            self.reset_scene = self._service(ResetScene, "/simulator/reset_scene")
            self.evaluate_task = self._service(EvaluateTask, "/simulator/evaluate_task")
            self.render_scene = self._service(RenderScene, "/simulator/render_scene")
            if model is None:
                self.action = self._action(Demonstrate, "/teacher/demonstrate")
            else:
                self.action = self._action(Execute, "/controller/execute")
                loaded = self._call(
                    self._service(LoadModel, "/controller/load_model"),
                    LoadModel.Request(model_path=str(model)),
                    "loading the model",
                )
                if not loaded.success:
                    raise ValueError(loaded.message)
        except BaseException:
            self.graph.close()
            raise

    @property
    def agent(self) -> str:
        return "teacher" if self.model is None else self.controller.model.kind

    def close(self):
        """Close the graph (once: a worker's evaluator may be closed before its process ends)."""
        if not self.closed:
            self.closed = True
            self.graph.close()

    def _service(self, srv_type, name):
        client = self.client.create_client(srv_type, name)
        if not client.wait_for_service(timeout_sec=30.0):
            raise RuntimeError(f"service {name} did not come up")
        return client

    def _action(self, action_type, name):
        client = ActionClient(self.client, action_type, name)
        if not client.wait_for_server(timeout_sec=30.0):
            raise RuntimeError(f"action {name} did not come up")
        return client

    def _call(self, client, request, what: str):
        return wait(client.call_async(request), SERVICE_TIMEOUT, what)

    def _run_goal(self, goal, what: str):
        handle = wait(self.action.send_goal_async(goal), SERVICE_TIMEOUT, f"{what} to be accepted")
        if not handle.accepted:
            raise RuntimeError(f"{what} was refused")
        return wait(handle.get_result_async(), EPISODE_TIMEOUT, what).result

    def run(self, situation, snapshot: pathlib.Path = None) -> EpisodeRecord:
        """One episode of the agent on situation, judged by the hidden metrics."""
        started = time.monotonic()
        grasp = situation.task == "grasp"
        record = unjudged_fields(situation, self.agent)
        situation_msg = messages.situation_to_msg(situation)
        bags_before = len(self.recorder.finished) if self.recorder is not None else 0
        if self.model is None:
            result = self._run_goal(
                Demonstrate.Goal(situation=situation_msg, episode_id=situation.name),
                f"the demonstration of '{situation.name}'",
            )
            if not result.metrics.task:  # the teacher could not run it (no metrics were computed)
                return EpisodeRecord(
                    **record,
                    wall_time_s=time.monotonic() - started,
                    outcome="failed",
                    message=result.message,
                )
            metrics, steps, outcome = result.metrics, result.steps, "demonstrated"
        else:
            reset = self._call(
                self.reset_scene, ResetScene.Request(situation=situation_msg), "the scene reset"
            )
            if not reset.success:
                return EpisodeRecord(
                    **record,
                    wall_time_s=time.monotonic() - started,
                    outcome="failed",
                    message=reset.message,
                )
            self._wait_for_scene(situation)
            result = self._run_goal(
                Execute.Goal(
                    max_steps=self.max_steps,
                    min_steps=min_steps_for(situation.perturbations, CONTROL_PERIOD),
                    episode_id=situation.name,
                ),
                f"the episode on '{situation.name}'",
            )
            if result.outcome == "failed":
                return EpisodeRecord(
                    **record,
                    wall_time_s=time.monotonic() - started,
                    outcome="failed",
                    message=result.message,
                )
            end_stamp = self._wait_for_last_command(situation.name) if result.steps else None
            if snapshot is not None:
                self._snapshot(snapshot / f"{situation.name}.png")
            evaluation = self._call(
                self.evaluate_task, EvaluateTask.Request(run_lift_test=grasp), "the metrics"
            )
            metrics, steps, outcome = evaluation.metrics, result.steps, result.outcome
            record["min_joint_margin"] = result.min_joint_limit_margin
            if self.recorder is not None and end_stamp is not None:
                self._publish_outcome(situation.name, metrics, end_stamp)
        if self.recorder is not None:
            self._wait_for_bag(situation.name, bags_before)
        if snapshot is not None and self.model is None:
            # after the lift test: the teacher judges itself
            self._snapshot(snapshot / f"{situation.name}.png")
        record.update(
            success=bool(metrics.success),
            min_distance=metrics.min_distance,
            collided=bool(metrics.collided),
            steps=int(steps),
            max_joint_overshoot=float(metrics.max_joint_overshoot),
            failure=metrics.failure,
        )
        if grasp:
            record.update(grasp_cost=metrics.grasp_cost, lift_passed=bool(metrics.lift_passed))
        else:
            record["lid_angle"] = metrics.lid_angle
        return EpisodeRecord(**record, wall_time_s=time.monotonic() - started, outcome=outcome)

    def _on_episode_event(self, event: EpisodeEvent):
        if event.event == EpisodeEvent.END:
            self._end_stamps[event.episode_id] = event.header.stamp

    def _wait_for_last_command(self, episode_id: str):
        """Wait until the simulator has simulated the period after the controller's last answered
        state (the stamp of the episode's END): the controller ends its episode as it publishes
        the last command, and the metrics must judge the state that command leads to, as the
        offline path does. Returns the END's stamp; RuntimeError if END or that period never
        comes."""
        deadline = time.monotonic() + SERVICE_TIMEOUT
        while episode_id not in self._end_stamps:
            if time.monotonic() > deadline:
                raise RuntimeError(f"the controller's END of '{episode_id}' never arrived")
            time.sleep(0.002)
        stamp = self._end_stamps.pop(episode_id)
        world = self.simulator.world
        last_ns = messages.time_ns(stamp) + world.control_period_ns
        while world.time_ns < last_ns:
            if time.monotonic() > deadline:
                raise RuntimeError(
                    f"the simulator never applied the last command of '{episode_id}'"
                )
            time.sleep(0.001)
        return stamp

    def _publish_outcome(self, episode_id: str, metrics, end_stamp):
        """--record: the OUTCOME of a controller episode, stamped as its END (the recorder then
        closes its bag)."""
        event = EpisodeEvent(
            event=EpisodeEvent.OUTCOME, episode_id=episode_id, source=self.agent, metrics=metrics
        )
        event.header.stamp = end_stamp
        self.outcome_pub.publish(event)

    def _wait_for_bag(self, episode_id: str, bags_before: int):
        """--record: wait until the recorder has closed the episode's bag (one more than
        bags_before); RuntimeError if it does not."""
        deadline = time.monotonic() + BAG_TIMEOUT
        while len(self.recorder.finished) <= bags_before:
            if time.monotonic() > deadline:
                raise RuntimeError(
                    f"the recorder did not finish the bag of '{episode_id}' "
                    f"within {BAG_TIMEOUT:g} s"
                )
            time.sleep(0.01)

    def _wait_for_scene(self, situation):
        """Wait until the controller has taken the new scene from /situation (latched,
        asynchronous); the controller takes it without its perturbations, which are the world's."""
        deadline = time.monotonic() + SERVICE_TIMEOUT
        unperturbed = situation.unperturbed()
        while True:
            scene = self.controller.scene
            if scene is not None and scene.situation == unperturbed:
                return
            if time.monotonic() > deadline:
                raise RuntimeError(
                    f"the controller never received the situation '{situation.name}'"
                )
            time.sleep(0.002)

    def _snapshot(self, path: pathlib.Path):
        answer = self._call(
            self.render_scene, RenderScene.Request(width=480, height=360), "a snapshot"
        )
        if answer.success:
            image = np.frombuffer(bytes(answer.image.data), dtype=np.uint8)
            write_png(path, image.reshape(answer.image.height, answer.image.width, 3))


def evaluate(
    situations,
    model=None,
    max_steps: int = 0,
    snapshots=None,
    progress=True,
    desc="evaluating",
    domain_id: int = None,
    jobs: int = 1,
    view=None,
    record=None,
    on_record=None,
    executor=None,
    robot: str = DEFAULT_ROBOT,
    controller: dict | None = None,
):
    """Run the agent (model file, or the teacher if None) of robot (a profile's name or file) on
    every situation; [EpisodeRecord] in the situations' order; on_record(record) (if given) as each
    episode ends. jobs > 1, or a Ray executor: that many workers of executor
    (tric_control.evaluation.executors; None: spawned processes here), worker k with its own
    Evaluator on DDS domain domain_id + k (domain_id None: the environment's ROS_DOMAIN_ID, else
    0). view: a FoxgloveView to show the run in (jobs 1 only); record: a folder for one bag per
    episode; controller: the controller node's other parameters (Evaluator's)."""
    task = evaluated_task(situations, jobs)
    jobs = min(jobs, len(situations))
    if view is not None and jobs > 1:
        raise ValueError("a live view shows one evaluation graph: use --jobs 1 with --viz")
    snapshot = pathlib.Path(snapshots) if snapshots else None
    bar = tqdm(total=len(situations), desc=desc, unit="episode", disable=not progress)
    try:
        if jobs > 1 or getattr(executor, "kind", "processes") != "processes":
            graphs = (task, model, max_steps, domain_id, record, robot, controller)
            run = (situations, snapshot, jobs, bar, on_record)
            return _evaluate_in_workers(*run, executor or ProcessExecutor(), graphs)
        evaluator = Evaluator(task, model, max_steps, domain_id, view, record, robot, controller)
        records = []
        try:
            for situation in situations:
                bar.set_postfix_str(situation.name)
                records.append(evaluator.run(situation, snapshot))
                bar.update()
                if on_record is not None:
                    on_record(records[-1])
        finally:
            evaluator.close()
        return records
    finally:
        bar.close()


def _evaluate_in_workers(situations, snapshot, jobs, bar, on_record, executor, graphs) -> list:
    """The situations shared out over jobs workers (_worker_evaluator), one at a time; graphs: what
    the workers' evaluation graphs are made of, (task, model, max_steps, domain_id, record, robot,
    controller) as evaluate's."""
    task, model, max_steps, domain_id, record, robot, controller = graphs
    base = int(os.environ.get("ROS_DOMAIN_ID", "0")) if domain_id is None else domain_id
    if not 0 <= base <= MAX_DOMAIN_ID - jobs + 1:
        raise ValueError(
            f"{jobs} workers from DDS domain {base} on would pass the last domain {MAX_DOMAIN_ID}"
        )
    record = None if record is None else str(pathlib.Path(record).resolve())
    arguments = (task, executor.ship(model), max_steps, base, record, robot, controller)
    agent = "teacher" if model is None else "model"
    return executor.run_episodes(
        situations, snapshot, jobs, bar, _worker_evaluator, lambda: arguments, agent, on_record
    )


def _worker_evaluator(
    worker, task, model, max_steps, base_domain, record, robot, controller
) -> Evaluator:
    """Worker k's Evaluator (see tric_control.evaluation.executors), on DDS domain base_domain + k;
    closed at the worker's exit."""
    domain, model = base_domain + worker, local_path(model)
    evaluator = Evaluator(task, model, max_steps, domain, None, record, robot, controller)
    multiprocessing.util.Finalize(None, evaluator.close, exitpriority=10)
    return evaluator
