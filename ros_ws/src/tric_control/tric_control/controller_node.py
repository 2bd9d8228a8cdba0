"""The controller node ("controller"): runs a learned model on the robot with motion-rate control.

A thin ROS shell around tric_control.motion_rate.MotionRateController: every control tick it reads
the measured joint positions q and the objects' poses, takes one motion-rate step (Eq. 8-9) on the
loaded model's objective and publishes the integrated position target.

Topics:
- subscribes /joint_states (sensor_msgs/JointState), /object_poses (tric_msgs/ObjectPoses) and
  /situation (tric_msgs/Situation, depth 1, transient_local, as the simulator latches it: the
  scene's table, obstacles and box are the geometry the collision priors keep the robot away from);
- publishes /joint_command (sensor_msgs/JointState: all of the robot's joints, by name, position
  targets in rad), /episode (tric_msgs/EpisodeEvent: START with the situation, END, or ABORT on
  failure or cancel; source = the model kind, e.g. "tric") and ~/status (tric_msgs/ControllerStatus,
  every tick while someone subscribes, with f, the step, the active constraints and the top
  features (tric_control.top_features); in realtime mode also while idle or holding).

Services and actions:
- ~/load_model (tric_msgs/srv/LoadModel): load a model file. Refused, keeping the current model,
  when the file is unreadable, was trained on another feature definition than this controller's
  task, is of a kind the controller cannot run (see tric_control.objectives.RUNNABLE_KINDS), or
  while an episode runs. A model trained with another version of this robot's profile loads with
  a warning, in the log and the response's message.
- ~/execute (tric_msgs/action/Execute): one episode from the current state, until the controller
  converges (the robot came to rest), the step budget is spent, the goal is canceled, or something
  fails (no model, no situation, no joint states for state_timeout_s). Feedback every 10 ticks. One
  goal at a time; others are rejected while one runs.

Parameters:
- task ("grasp" | "open_box", default "grasp"): the feature definition models must match.
- model_path (string, default ""): a model file to load at start.
- mode ("lockstep" | "realtime", default "lockstep"): see below.
- control_rate_hz (default 100): control ticks per second; the step bound of a tick is the joints'
  velocity limits divided by this rate.
- max_steps (default: the task's, tric_control.episode_runner.DEFAULT_MAX_STEPS: 1200 for grasps,
  2000 for boxes): an episode's step budget when the goal gives none.
- state_timeout_s (default 10): wall seconds without joint states before an episode aborts.
- fall_pace_knee (default 0.25, in [0, 1]): the controller asks a share of its delta that follows
  the fall f makes once f falls less than this share of what it asks
  (tric_control.fall_pace.FallPace, docs/decisions/fall-pace.md); 0: the paper's constant delta.
  Models that ask no fall (DPL) run without.
- stall_escapes (default 3, >= 0): a rest with f far above where the model's own rollouts from its
  demonstrations' starts came to rest (its done_value) is a stall; the controller walks the arm
  to a random nearby configuration and descends again, at most this many times an episode
  (tric_control.stall_escape, docs/decisions/stall-escape.md); 0: a stall is a rest, as in the
  paper.
- use_sim_time: as usual. Realtime mode's timer and staleness test run on the node clock, which must
  be the clock the joint states are stamped with (with the simulator: use_sim_time true).

Modes: "lockstep" (tric_control.loops.lockstep: each joint state of the simulator in lockstep
answered with exactly one command, stamped as the state) and "realtime"
(tric_control.loops.realtime: a timer on the node clock commands from the latest joint state, and
holds when it is stale). The loaded model, the scene and the running episode are
tric_control.loops.episode's.

The episode itself (safe commands, the stale-state hold, convergence and the step budget, the
statistics) is tric_control.episode_runner.EpisodeRunner, the same loop that `tric-eval --offline`
runs on the physics without ROS; this node only feeds it states and publishes what it decides.
"""

import math
import sys
import threading

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.node import Node
from sensor_msgs.msg import JointState

from tric_control.controller_parameters import declare_parameters
from tric_control.episode_runner import EpisodeRunner
from tric_control.loops.episode import Episode, Loaded, Scene
from tric_control.loops.lockstep import LockstepLoop
from tric_control.loops.realtime import RealtimeLoop
from tric_control.motion_rate import MotionRateController
from tric_control.objectives import make_objective
from tric_learning.features import FeatureDefinition
from tric_learning.model_file import ModelFile
from tric_msgs.action import Execute
from tric_msgs.msg import ControllerStatus, EpisodeEvent
from tric_msgs.msg import Situation as SituationMsg
from tric_msgs.srv import LoadModel
from tric_sim.ros import messages
from tric_sim.ros.graph import EVENT_QOS, LATCHED_QOS, STATE_QOS, run_node
from tric_sim.ros.parameters import declare_robot
from tric_sim.ros.topic_poller import command_msg
from tric_sim.world.proximity import Proximity
from tric_sim.world.scene import task_grip

FEEDBACK_EVERY = 10


class ControllerNode(Node):
    """Serves ~/load_model and ~/execute (see the module docstring)."""

    def __init__(self, **kwargs):
        super().__init__("controller", **kwargs)
        self.parameters = declare_parameters(self)
        self.task, self.mode = self.parameters.task, self.parameters.mode
        self.max_steps = self.parameters.max_steps
        self.state_timeout = self.parameters.state_timeout_s
        model_path, rate = self.parameters.model_path, self.parameters.control_rate_hz
        self.period = 1.0 / rate
        self.period_ns = int(round(1e9 / rate))
        self.robot = declare_robot(self)
        self.definition = FeatureDefinition.for_task(self.task, self.robot)
        self.model = None
        self.scene = None
        self._busy = threading.Lock()
        self._stop = threading.Event()
        if model_path:
            self.model = self._load(model_path)  # ValueError: a bad parameter

        self.command_pub = self.create_publisher(JointState, "/joint_command", STATE_QOS)
        self.episode_pub = self.create_publisher(EpisodeEvent, "/episode", EVENT_QOS)
        self.status_pub = self.create_publisher(ControllerStatus, "~/status", STATE_QOS)
        self.create_subscription(SituationMsg, "/situation", self._on_situation, LATCHED_QOS)
        self.loop = LockstepLoop(self) if self.mode == "lockstep" else RealtimeLoop(self)
        self.create_service(LoadModel, "~/load_model", self._on_load_model)
        self._server = ActionServer(
            self,
            Execute,
            "~/execute",
            execute_callback=self._execute,
            goal_callback=self._on_goal,
            cancel_callback=lambda _: CancelResponse.ACCEPT,
        )
        self.get_logger().info(
            f"controller for '{self.task}' in {self.mode} mode at {rate:g} Hz; model: "
            + (
                f"{self.model.path} ({self.model.kind})"
                if self.model
                else "none (call ~/load_model)"
            )
        )

    def destroy_node(self):
        self._stop.set()
        self.loop.stop()
        self._server.destroy()
        self.loop.destroy()
        return super().destroy_node()

    # --- model and scene -----------------------------------------------------------------------

    def _load(self, path: str) -> Loaded:
        """The model at path, ready to run, or ValueError saying why not."""
        if not path:
            raise ValueError("no model path given")
        try:
            model_file = ModelFile.load(path, self.definition)
            objective = make_objective(model_file, self.robot, self.period)
        except ValueError:
            raise
        except Exception as error:  # anything else a damaged file provokes: still a clear refusal
            raise ValueError(
                f"{path} could not be loaded: {type(error).__name__}: {error}"
            ) from None
        return Loaded(path, model_file, objective)

    def _on_load_model(self, request, response):
        if not self._busy.acquire(blocking=False):
            response.success = False
            response.message = "refused: an episode is running (cancel it or wait for its end)"
            self.get_logger().warning(f"load_model {request.model_path}: {response.message}")
            return response
        try:
            loaded = self._load(request.model_path)
        except ValueError as error:
            response.success = False
            response.message = (
                f"model refused, keeping {self.model.path if self.model else 'no model'}: {error}"
            )
            self.get_logger().warning(response.message)
            return response
        finally:
            self._busy.release()
        self.model = loaded
        definition = loaded.file.definition
        response.success = True
        response.message = f"loaded {loaded.kind} model {loaded.path}"
        response.model_kind, response.task = loaded.kind, definition.task
        response.fingerprint = definition.fingerprint
        response.input_features = definition.size
        self.get_logger().info(response.message)
        change = self.robot.profile.change_since(
            loaded.file.info.get("robot_profile", ""), f"model {loaded.path}"
        )
        if change:
            response.message += f" ({change})"
            self.get_logger().warning(change)
        return response

    def _on_situation(self, msg: SituationMsg):
        try:
            # the perturbations are the world's doing, not the controller's: a situation that
            # gained some mid-episode (the simulator's ~/perturb) is the same scene
            situation = messages.situation_from_msg(msg, self.robot.n_joints).unperturbed()
            if self.scene is not None and self.scene.situation == situation:
                return  # the same scene again (e.g. a reset to the same situation): nothing changed
            proximity = Proximity(self.robot, situation)
        except ValueError as error:
            self.get_logger().warning(f"ignored /situation '{msg.name}': {error}")
            return
        self.scene = Scene(situation, msg, proximity)

    # --- the action ------------------------------------------------------------------------------

    def _on_goal(self, goal):
        if not self._busy.acquire(blocking=False):
            self.get_logger().warning("episode refused: another one is running")
            return GoalResponse.REJECT
        self._busy.release()
        return GoalResponse.ACCEPT

    async def _execute(self, goal_handle):
        with self._busy:
            return await self._run(goal_handle)

    async def _run(self, goal_handle):
        goal = goal_handle.request
        result = Execute.Result(
            outcome="failed",
            initial_value=math.nan,
            final_value=math.nan,
            min_distance=math.nan,
            min_joint_limit_margin=math.nan,
            mean_tick_ms=math.nan,
            max_tick_ms=math.nan,
        )
        model, scene = self.model, self.scene
        if model is None:
            return self._abort(
                goal_handle,
                result,
                "no model loaded: call ~/load_model first (or set the model_path parameter)",
            )
        if scene is None:
            return self._abort(
                goal_handle,
                result,
                "no situation known: nothing was published on /situation "
                "(is the simulator running?)",
            )
        if scene.situation.task != self.task:
            return self._abort(
                goal_handle,
                result,
                f"the current situation '{scene.situation.name}' is a "
                f"'{scene.situation.task}' task; this controller runs '{self.task}'",
            )
        controller = MotionRateController(
            self.robot,
            scene.proximity,
            model.objective,
            self.period,
            fall_pace=self.parameters.fall_pace(model.objective),
        )
        max_steps = int(goal.max_steps) or self.max_steps
        runner = EpisodeRunner(
            self.robot,
            controller,
            max_steps,
            self.period,
            model.objects,
            lambda what: self.get_logger().warning(what, throttle_duration_sec=1.0),
            task_grip(self.task, self.robot.profile),
            int(goal.min_steps),
            self.parameters.escape(),
        )
        episode = Episode(
            goal_handle, goal.episode_id or scene.situation.name, model, scene, runner
        )
        self.get_logger().info(
            f"episode '{episode.episode_id}' ({model.kind}, {max_steps} steps at most)"
        )
        outcome, message = await self.loop.run(episode)
        episode.fill(result)
        result.outcome, result.message = outcome, message
        if outcome == "canceled":
            self._event(EpisodeEvent.ABORT, episode)
            goal_handle.canceled()
            self.get_logger().info(
                f"episode '{episode.episode_id}' canceled after {episode.steps} steps"
            )
            return result
        if outcome == "failed":
            self._event(EpisodeEvent.ABORT, episode)
            return self._abort(goal_handle, result, message)
        self._event(EpisodeEvent.END, episode)
        result.success = True
        self.get_logger().info(f"episode '{episode.episode_id}': {message}")
        goal_handle.succeed()
        return result

    def _abort(self, goal_handle, result, message):
        self.get_logger().error(f"episode aborted: {message}")
        result.success, result.message, result.outcome = False, message, "failed"
        goal_handle.abort()
        return result

    def _event(self, kind, episode: Episode):
        """Publish an EpisodeEvent; END and ABORT only for an episode that started."""
        msg = episode.event(kind)
        if msg is not None:
            self.episode_pub.publish(msg)

    # --- one tick (both modes) -------------------------------------------------------------------

    def _tick(self, episode: Episode, stamp_ns: int, q, poses, status_ns: int, now_ns: int = None):
        """One runner step from the state stamped stamp_ns (at now_ns: realtime's staleness test):
        command, status, feedback. Returns (outcome, message) when the episode is over, else None;
        raises RuntimeError."""
        if episode.start_ns is None:
            episode.start_ns = stamp_ns
            self._event(EpisodeEvent.START, episode)
        decided = episode.runner.step(q, poses, stamp_ns, now_ns)
        held = bool(decided.held)  # stale input: the runner held without deciding anything
        self.command_pub.publish(
            command_msg(
                self.robot.joint_names,
                decided.command,
                now_ns if held and now_ns is not None else stamp_ns,
            )
        )
        if held:
            if "no pose" in decided.held:
                self.get_logger().warning(
                    f"holding: {decided.held} on /object_poses", throttle_duration_sec=1.0
                )
            self._status(ControllerStatus.HOLDING, status_ns, episode)
            return None
        episode.last_ns = stamp_ns
        if decided.tick is None:  # at rest (the task's grip closing, then held): not stepped
            state = ControllerStatus.GRIPPING if decided.gripping else ControllerStatus.CONVERGED
            self._status(state, status_ns, episode)
            return decided.outcome
        tick, steps = decided.tick, episode.steps
        if steps % FEEDBACK_EVERY == 0:
            episode.goal_handle.publish_feedback(
                Execute.Feedback(
                    step=steps,
                    value=float(tick.value),
                    step_norm=decided.step_norm,
                    min_distance=float(tick.min_distance),
                )
            )
        if self.status_pub.get_subscription_count() == 0:
            return decided.outcome  # a status no one reads costs a quarter of a lockstep tick
        status = ControllerStatus(
            state=ControllerStatus.CONVERGED if tick.converged else ControllerStatus.RUNNING,
            model_path=episode.model.path,
            step=steps,
            value=float(tick.value),
            value_rate=float(getattr(episode.model.objective, "delta", math.nan)),
            gradient_norm=float(tick.gradient_norm),
            step_norm=decided.step_norm,
            min_distance=float(tick.min_distance),
            active_constraints=list(tick.active),
            tick_time_ms=decided.tick_ms,
        )
        status.feature_names, status.feature_values, status.feature_gradients = (
            episode.model.top_features.read()
        )
        status.header.stamp = messages.time_msg(status_ns)
        self.status_pub.publish(status)
        return decided.outcome

    # --- status (both modes) --------------------------------------------------------------------

    def _status(self, state, now_ns: int, episode: Episode = None):
        status = ControllerStatus(
            state=state,
            model_path=self.model.path if self.model else "",
            value=math.nan,
            value_rate=math.nan,
            gradient_norm=math.nan,
            min_distance=math.nan,
            tick_time_ms=0.0,
        )
        if episode is not None:
            status.step = episode.steps
            status.model_path = episode.model.path
            status.value = episode.runner.stats.final_value
            status.value_rate = float(getattr(episode.model.objective, "delta", math.nan))
        status.header.stamp = messages.time_msg(now_ns)
        self.status_pub.publish(status)


def main(args=None):
    return run_node(ControllerNode, "controller", args)


if __name__ == "__main__":
    sys.exit(main())
