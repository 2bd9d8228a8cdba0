"""The controller node in-process: model loading and refusals, a lockstep episode on the simulator
node, realtime holds (stale joint states, object poses without the object) and the resume on fresh
states, refused episodes, and the simulator stopping mid-episode."""

import numpy as np
import pytest
from action_msgs.msg import GoalStatus
from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from conftest import HANG_S, call, run_action, run_periods, wait_for, wait_future
from tric_control.controller_node import ControllerNode
from tric_control.fall_pace import FallPace
from tric_learning import model_file
from tric_learning.features import FeatureDefinition
from tric_learning.recording import record_offline
from tric_learning.training.value import TrainingConfig, train
from tric_msgs.action import Execute
from tric_msgs.msg import ControllerStatus, EpisodeEvent, ObjectPoses
from tric_msgs.msg import Situation as SituationMsg
from tric_msgs.srv import LoadModel, ResetScene
from tric_sim.ros import messages
from tric_sim.simulator_node import SimulatorNode
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

#: The default robot's start configuration, rad.
HOME = RobotModel().home

#: Test subscriptions keep every message (the checks compare consecutive commands).
KEEP_ALL = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
LATCHED = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture(scope="module")
def model_path(tmp_path_factory, robot):
    """A tiny TRIC grasp model (3 demonstrations, 5 hidden units): fast to make, not meant to
    grasp."""
    dataset = record_offline(robot, situations.sphere_grid()[12:15], 5.0)
    result = train(
        dataset, robot, TrainingConfig(hidden_units=5, noisy_samples=10, max_iterations=20)
    )
    return str(
        model_file.from_training(result, dataset).save(
            tmp_path_factory.mktemp("model") / "model.safetensors"
        )
    )


class Observer(Node):
    """Records what the controller publishes."""

    def __init__(self, context):
        super().__init__("test_observer", context=context)
        self.commands, self.statuses, self.events = [], [], []
        self.create_subscription(JointState, "/joint_command", self.commands.append, KEEP_ALL)
        self.create_subscription(
            ControllerStatus, "/controller/status", self.statuses.append, KEEP_ALL
        )
        self.create_subscription(EpisodeEvent, "/episode", self.events.append, KEEP_ALL)


def make_controller(context, **parameters):
    return ControllerNode(
        context=context,
        parameter_overrides=[Parameter(name, value=value) for name, value in parameters.items()],
    )


def load(observer, path):
    return call(observer, LoadModel, "/controller/load_model", LoadModel.Request(model_path=path))


def test_load_model_refuses_bad_files_and_keeps_the_current_model(
    ros_context, spin, robot, model_path, tmp_path
):
    controller = make_controller(ros_context)
    observer = spin(controller, Observer(ros_context))[1]
    good = load(observer, model_path)
    assert good.success and "another version" not in good.message, good.message
    assert (good.model_kind, good.task) == ("tric", "grasp")
    grasp = FeatureDefinition.for_task("grasp", robot)
    assert good.fingerprint == grasp.fingerprint and good.input_features == grasp.size == 224

    text = tmp_path / "notes.safetensors"
    text.write_text("not a model\n" * 20)
    box = model_file.ModelFile(
        "tric",
        FeatureDefinition.for_task("open_box", robot),
        {"w1": np.zeros((2, 3))},
        {"delta": 0.1, "rho": 1.0},
    ).save(tmp_path / "box.safetensors")
    dpl = model_file.ModelFile("dpl_joint", grasp, {"w": np.zeros(3)}).save(
        tmp_path / "dpl.safetensors"
    )
    refusals = {
        str(tmp_path / "missing.safetensors"): "does not exist",
        str(text): "not a readable model file",
        str(box): "another feature definition",
        str(dpl): "cannot be run",
        "": "no model path",
    }
    for path, reason in refusals.items():
        response = load(observer, path)
        assert not response.success and reason in response.message, response.message
        assert f"keeping {model_path}" in response.message
    assert controller.model.path == model_path

    # trained with another version of this robot's profile: loaded, and the response says so
    trained = model_file.ModelFile.load(model_path)
    assert trained.info["robot_profile"] == robot.profile.identity
    trained.info["robot_profile"] = f"{robot.profile.name}:{'0' * 64}"
    edited = trained.save(tmp_path / "edited_profile.safetensors")
    response = load(observer, str(edited))
    assert response.success, response.message
    assert "another version of the robot profile 'tric_arm_hand'" in response.message
    assert f"now {robot.profile.digest[:12]}" in response.message
    assert controller.model.path == str(edited)


def test_lockstep_episode_on_the_simulator(ros_context, spin, robot, model_path):
    simulator = SimulatorNode(
        context=ros_context, parameter_overrides=[Parameter("mode", value="lockstep")]
    )
    controller = make_controller(ros_context, mode="lockstep")
    observer = spin(simulator, controller, Observer(ros_context))[2]
    situation = situations.dataset("sphere_test")[0]
    reset = call(
        observer,
        ResetScene,
        "/simulator/reset_scene",
        ResetScene.Request(situation=messages.situation_to_msg(situation)),
    )
    assert reset.success, reset.message
    assert load(observer, model_path).success
    wait_for(
        lambda: controller.scene is not None and controller.scene.situation == situation,
        what="the situation",
    )
    status, result, feedback = run_action(
        observer, Execute, "/controller/execute", Execute.Goal(max_steps=150, episode_id="ctl_test")
    )
    assert status == GoalStatus.STATUS_SUCCEEDED, result.message
    assert result.success and result.outcome in ("step_budget", "converged")
    assert 0 < result.steps <= 150
    assert np.isfinite(result.initial_value) and np.isfinite(result.final_value)
    assert np.isfinite(result.min_distance) and np.isfinite(result.min_joint_limit_margin)
    assert 0 < result.mean_tick_ms <= result.max_tick_ms
    assert [f.step for f in feedback] == list(range(10, result.steps + 1, 10))

    wait_for(
        lambda: len(observer.commands) >= result.steps and len(observer.statuses) >= result.steps,
        what="every command and status",
    )
    commands = np.array([observer.commands[k].position for k in range(result.steps)])
    assert list(observer.commands[0].name) == list(robot.joint_names)
    assert np.all(commands >= robot.lower) and np.all(commands <= robot.upper)
    start = messages.joint_positions_from_msg(reset.joint_state, robot.joint_names)
    steps = np.abs(np.diff(np.vstack([start, commands]), axis=0))
    assert np.all(steps <= robot.velocity_limits * 0.01 + 1e-9)
    stamps = [messages.time_ns(c.header.stamp) for c in observer.commands[: result.steps]]
    assert np.all(np.diff(stamps) == 10_000_000)  # one command per simulated period, none skipped
    assert {s.state for s in observer.statuses} <= {
        ControllerStatus.RUNNING,
        ControllerStatus.CONVERGED,
    }
    assert observer.statuses[-1].step == result.steps and observer.statuses[0].value_rate > 0

    wait_for(lambda: len(observer.events) >= 2, what="START and END")
    start_event, end_event = observer.events[:2]
    assert (start_event.event, end_event.event) == (EpisodeEvent.START, EpisodeEvent.END)
    assert start_event.source == end_event.source == "tric" and start_event.episode_id == "ctl_test"
    assert start_event.situation.name == situation.name
    assert messages.time_ns(end_event.header.stamp) == stamps[-1]


class Feeder(Node):
    """Plays the robot for a realtime controller: every 10 ms (wall clock) it publishes the joint
    state `q` stamped now if `states`, and the object poses if `poses` (`object_pose` False: poses
    without the object)."""

    def __init__(self, context, names, situation):
        super().__init__("test_feeder", context=context)
        self.names, self.q = names, HOME.copy()
        self.states, self.poses, self.object_pose = True, True, True
        self.object = (situation.object_position, situation.object_orientation)
        self.state_pub = self.create_publisher(JointState, "/joint_states", 10)
        self.poses_pub = self.create_publisher(ObjectPoses, "/object_poses", 10)
        self.create_timer(0.01, self.publish)

    def publish(self):
        now = self.get_clock().now().nanoseconds
        if self.poses:
            self.poses_pub.publish(
                messages.object_poses_msg({"object": self.object} if self.object_pose else {}, now)
            )
        if self.states:
            self.state_pub.publish(
                messages.joint_state_msg(self.names, self.q, np.zeros(len(self.q)), now)
            )


def test_realtime_holds_on_stale_states_and_missing_poses_and_resumes(
    ros_context, spin, model_path
):
    """Realtime: fresh states and poses step the controller; states that stop coming make it hold
    the last measured positions (HOLDING); fresh states again resume the stepping; poses without the
    object hold it although the states are fresh; a cancel ends the episode."""
    controller = make_controller(ros_context, mode="realtime", model_path=model_path)
    observer = Observer(ros_context)
    situation_pub = observer.create_publisher(SituationMsg, "/situation", LATCHED)
    situation = situations.dataset("sphere_test")[0]
    feeder = Feeder(ros_context, controller.robot.joint_names, situation)
    feeder.states = feeder.poses = False
    spin(controller, observer, feeder)
    situation_pub.publish(messages.situation_to_msg(situation))
    wait_for(lambda: controller.scene is not None, what="the situation")
    wait_for(
        lambda: any(s.state == ControllerStatus.IDLE for s in observer.statuses), what="idle status"
    )

    client = ActionClient(observer, Execute, "/controller/execute")
    assert client.wait_for_server(timeout_sec=HANG_S)
    goal_future = client.send_goal_async(Execute.Goal(max_steps=100000))
    handle = wait_future(goal_future, what="goal response")
    assert handle.accepted

    def statuses_since(stamp_ns):
        """The statuses of the ticks after stamp_ns (the node's clock)."""
        return [s for s in list(observer.statuses) if messages.time_ns(s.header.stamp) > stamp_ns]

    feeder.states = feeder.poses = True
    wait_for(
        lambda: any(s.state == ControllerStatus.RUNNING for s in observer.statuses),
        what="running ticks",
    )
    feeder.states = False  # the robot stops answering

    def holding():
        return (
            observer.statuses
            and observer.statuses[-1].state == ControllerStatus.HOLDING
            and observer.commands
            and np.allclose(observer.commands[-1].position, HOME, rtol=0, atol=1e-12)
        )

    wait_for(holding, what="a hold command at the last positions and status HOLDING")
    held_at, mark = observer.statuses[-1].step, messages.time_ns(observer.statuses[-1].header.stamp)
    run_periods(observer)
    assert len(statuses_since(mark)) >= 10 and {s.step for s in statuses_since(mark)} == {held_at}

    refused = load(observer, model_path)
    assert not refused.success and "episode is running" in refused.message
    second = client.send_goal_async(Execute.Goal(max_steps=10))
    assert not wait_future(second, what="goal response").accepted

    # fresh states again: the controller resumes
    feeder.states = True
    wait_for(
        lambda: any(
            s.state == ControllerStatus.RUNNING and s.step > held_at for s in observer.statuses
        ),
        what="running ticks after the hold",
    )

    feeder.object_pose = False  # fresh states, poses without the object
    wait_for(lambda: controller.loop.poses == {}, what="poses without the object")
    mark = controller.get_clock().now().nanoseconds
    run_periods(observer)
    without_object = statuses_since(mark)
    assert len(without_object) >= 10
    assert {s.state for s in without_object} == {ControllerStatus.HOLDING}
    assert len({s.step for s in without_object}) == 1  # the controller is not stepped
    wait_for(
        lambda: np.allclose(observer.commands[-1].position, HOME, rtol=0, atol=1e-12),
        what="the hold command reaching the measured positions",
    )

    result_future = handle.get_result_async()
    handle.cancel_goal_async()
    wrapped = wait_future(result_future, what="the result")
    assert wrapped.status == GoalStatus.STATUS_CANCELED and wrapped.result.outcome == "canceled"
    assert wrapped.result.steps > held_at
    wait_for(
        lambda: [e.event for e in observer.events] == [EpisodeEvent.START, EpisodeEvent.ABORT],
        what="START and ABORT",
    )
    client.destroy()


def test_execute_is_refused_without_model(ros_context, spin):
    without_model = make_controller(ros_context)
    observer = spin(without_model, Observer(ros_context))[1]
    status, result, _ = run_action(
        observer, Execute, "/controller/execute", Execute.Goal(max_steps=10)
    )
    assert status == GoalStatus.STATUS_ABORTED and not result.success
    assert result.outcome == "failed" and "no model loaded" in result.message
    run_periods(observer)
    assert not observer.events


def test_execute_is_refused_without_situation(ros_context, spin, model_path):
    controller = make_controller(ros_context, model_path=model_path)
    observer = spin(controller, Observer(ros_context))[1]
    status, result, _ = run_action(
        observer, Execute, "/controller/execute", Execute.Goal(max_steps=10)
    )
    assert status == GoalStatus.STATUS_ABORTED and "no situation known" in result.message
    run_periods(observer)
    assert not observer.events


def test_lockstep_episode_aborts_without_joint_states(ros_context, spin, model_path):
    controller = make_controller(ros_context, model_path=model_path, state_timeout_s=0.3)
    observer = Observer(ros_context)
    situation_pub = observer.create_publisher(SituationMsg, "/situation", LATCHED)
    spin(controller, observer)
    situation_pub.publish(messages.situation_to_msg(situations.dataset("sphere_test")[0]))
    wait_for(lambda: controller.scene is not None, what="the situation")
    status, result, _ = run_action(
        observer, Execute, "/controller/execute", Execute.Goal(max_steps=10)
    )
    assert status == GoalStatus.STATUS_ABORTED and "no joint states for 0.3 s" in result.message
    run_periods(observer)
    assert result.steps == 0 and not observer.commands and not observer.events


def _reset_scene(observer, controller):
    """The simulator's scene reset to another situation."""
    other = situations.dataset("sphere_test")[1]
    assert call(
        observer,
        ResetScene,
        "/simulator/reset_scene",
        ResetScene.Request(situation=messages.situation_to_msg(other)),
    ).success


def _raising_tick(observer, controller):
    """The controller's next tick raises (a bug)."""

    def tick(*_):
        raise ZeroDivisionError("a bug")

    controller._tick = tick


def start_long_episode(observer, controller, commands: int, model_path=None):
    """Reset the scene to the first sphere test situation (and load model_path, if given), start
    an episode of 100000 steps at most and wait for its first commands; (the action client, the
    result's future)."""
    situation = situations.dataset("sphere_test")[0]
    assert call(
        observer,
        ResetScene,
        "/simulator/reset_scene",
        ResetScene.Request(situation=messages.situation_to_msg(situation)),
    ).success
    if model_path is not None:
        assert load(observer, model_path).success
    wait_for(
        lambda: controller.scene is not None and controller.scene.situation == situation,
        what="the situation",
    )
    client = ActionClient(observer, Execute, "/controller/execute")
    assert client.wait_for_server(timeout_sec=HANG_S)
    handle = wait_future(client.send_goal_async(Execute.Goal(max_steps=100000)), what="goal")
    result_future = handle.get_result_async()
    wait_for(
        lambda: len(observer.commands) >= commands or result_future.done(),
        what=f"{commands} commands",
    )
    return client, result_future


def _stopping(observer, controller):
    """The controller begins to shut down (destroy_node sets its stop event first)."""
    controller._stop.set()


@pytest.mark.parametrize(
    "interrupt, message",
    [
        (_reset_scene, "the scene was reset during the episode"),
        (_raising_tick, "internal error: ZeroDivisionError: a bug"),
        (_stopping, "the controller is shutting down"),
    ],
    ids=["reset", "raising tick", "shutdown"],
)
def test_an_episode_interrupted_aborts_with_the_reason_and_an_abort_event(
    ros_context, spin, model_path, interrupt, message
):
    simulator = SimulatorNode(context=ros_context)
    controller = make_controller(ros_context, model_path=model_path)
    observer = Observer(ros_context)
    spin(simulator, controller, observer)
    client, result_future = start_long_episode(observer, controller, 10)
    assert not result_future.done(), f"the episode ended early: {result_future.result().result}"
    interrupt(observer, controller)
    wrapped = wait_future(result_future, what="the abort")
    assert wrapped.status == GoalStatus.STATUS_ABORTED
    assert (wrapped.result.outcome, wrapped.result.message) == ("failed", message)
    wait_for(lambda: len(observer.events) >= 2, what="START and ABORT")
    assert [e.event for e in observer.events] == [EpisodeEvent.START, EpisodeEvent.ABORT]
    client.destroy()


@pytest.mark.parametrize(
    "name, value, reason",
    [
        ("mode", "fast", "parameter mode"),
        ("task", "juggle", "parameter task"),
        ("control_rate_hz", 0.0, "control_rate_hz"),
        ("max_steps", "many", "an integer"),
        ("state_timeout_s", -1.0, "state_timeout_s"),
        ("model_path", "/no/such/model.safetensors", "does not exist"),
        ("fall_pace_knee", 1.5, r"fall_pace_knee must be in \[0, 1\]"),
        ("fall_pace_knee", -0.1, r"fall_pace_knee must be in \[0, 1\]"),
    ],
)
def test_bad_parameters_are_refused(ros_context, name, value, reason):
    with pytest.raises(ValueError, match=reason):
        make_controller(ros_context, **{name: value})


def test_the_fall_pace_is_the_node_s_by_default_and_none_at_knee_zero_or_without_delta(
    ros_context, model_path
):
    """The value model's objective asks a fall: the node paces it with its knee (0.25 unless set),
    not at all at knee 0 (the paper's constant delta); an objective that asks no fall (DPL's) runs
    without."""
    default = make_controller(ros_context, model_path=model_path)
    objective = default.model.objective
    assert objective.delta > 0
    assert default.parameters.fall_pace(objective) == FallPace(knee=0.25)
    assert default.parameters.fall_pace(object()) is None
    half = make_controller(ros_context, fall_pace_knee=0.5).parameters
    assert half.fall_pace(objective) == FallPace(knee=0.5)
    assert make_controller(ros_context, fall_pace_knee=0).parameters.fall_pace(objective) is None


@pytest.mark.parametrize("mode", ["lockstep", "realtime"])
def test_the_simulator_stopping_mid_episode_leaves_the_robot_held_and_aborts(
    ros_context, executor, spin, model_path, mode
):
    simulator = SimulatorNode(
        context=ros_context, parameter_overrides=[Parameter("mode", value=mode)]
    )
    controller = make_controller(
        ros_context, mode=mode, state_timeout_s=2.0, use_sim_time=mode == "realtime"
    )
    observer = Observer(ros_context)
    states = []
    observer.create_subscription(JointState, "/joint_states", states.append, KEEP_ALL)
    spin(simulator, controller, observer)
    client, result_future = start_long_episode(observer, controller, 30, model_path)
    # an episode that ended before the simulator stopped says why (a stall of the loaded test
    # machine longer than state_timeout_s aborts it early)
    assert not result_future.done(), f"the episode ended early: {result_future.result().result}"
    executor.remove_node(simulator)  # the simulator stops in the middle of the episode
    simulator.destroy_node()
    wrapped = wait_future(result_future, what="the abort")
    assert wrapped.status == GoalStatus.STATUS_ABORTED and wrapped.result.outcome == "failed"
    assert wrapped.result.message.startswith("no joint states for 2 s: is the")
    # the robot holds: no command moves it on after the last state (lockstep answers states only;
    # realtime holds the last measured positions once the state is STALE_PERIODS periods old)
    run_periods(observer)
    last_state = messages.time_ns(states[-1].header.stamp)
    after = [c for c in observer.commands if messages.time_ns(c.header.stamp) > last_state]
    assert len(after) <= 3 and (mode == "realtime" or not after)
    assert all(np.allclose(c.position, states[-1].position, atol=1e-3) for c in after)
    wait_for(
        lambda: observer.events and observer.events[-1].event == EpisodeEvent.ABORT,
        what="ABORT on /episode",
    )
    client.destroy()
