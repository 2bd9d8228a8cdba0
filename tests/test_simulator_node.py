"""The simulator node in-process: lockstep commanding, refused commands, services, latched
situation."""

import math

import numpy as np
import pytest
from rclpy.node import Node
from rclpy.parameter import Parameter
from rclpy.qos import DurabilityPolicy, QoSProfile
from sensor_msgs.msg import JointState

from conftest import call, publisher_matches, run_periods, wait_for
from tric_msgs.msg import ObjectPoses, Perturbation
from tric_msgs.msg import Situation as SituationMsg
from tric_msgs.srv import EvaluateTask, Perturb, RenderScene, ResetScene
from tric_sim.ros import messages
from tric_sim.simulator_node import IN_PROCESS_LOCKSTEP_TIMEOUT_S, SimulatorNode
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

#: The default robot's start configuration, rad.
HOME = RobotModel().home


class Commander(Node):
    """Answers every /joint_states with a position target (lockstep: the same stamp); an empty
    target () answers with an empty command, which holds the simulator's targets."""

    def __init__(self, context, target=None):
        super().__init__("test_commander", context=context)
        self.target = target
        self.states = []
        self.poses = []
        self.publisher = self.create_publisher(JointState, "/joint_command", 10)
        self.create_subscription(JointState, "/joint_states", self.on_state, 10)
        self.create_subscription(ObjectPoses, "/object_poses", self.poses.append, 10)

    def on_state(self, msg):
        self.states.append(msg)
        if self.target is not None:
            names = list(msg.name) if len(self.target) else []
            command = JointState(name=names, position=list(self.target))
            command.header.stamp = msg.header.stamp
            self.publisher.publish(command)


def make_simulator(context, mode="lockstep", timeout=1.0):
    return SimulatorNode(
        context=context,
        parameter_overrides=[
            Parameter("mode", value=mode),
            Parameter("lockstep_timeout_s", value=timeout),
        ],
    )


def test_lockstep_commander_drives_the_arm_to_a_target(ros_context, spin):
    target = HOME.copy()
    target[[0, 1, 3]] += [0.4, -0.2, 0.3]
    simulator = make_simulator(ros_context)
    commander = Commander(ros_context, target)
    spin(simulator, commander)
    wait_for(lambda: len(commander.states) > 150, what="150 lockstep periods")
    stamps = [messages.time_ns(s.header.stamp) for s in commander.states]
    # one state per 10 ms of simulated time, none skipped
    assert np.all(np.diff(stamps) == 10_000_000)
    final = np.array(commander.states[-1].position)
    assert np.abs(final - target).max() < 0.01  # docs/design.md 6's joint tolerance, 0.01 rad
    assert commander.poses and commander.poses[-1].names[0] == "object"


def test_bad_commands_are_refused_and_the_joints_hold(ros_context, spin):
    simulator = make_simulator(ros_context, timeout=0.01)  # no commander answers: step on timeout
    commander = Commander(ros_context)
    spin(simulator, commander)
    wait_for(lambda: commander.states, what="joint states")
    names = list(commander.states[-1].name)
    bad = [
        JointState(name=names, position=[math.nan] * 14),
        JointState(name=names[:3], position=[0.0] * 4),
        JointState(name=names, position=[3.5] * 14),
        JointState(name=["elbow"], position=[0.1]),
    ]
    for command in bad:
        commander.publisher.publish(command)  # zero stamp: applies to whatever period is current
    wait_for(lambda: len(commander.states) > 40, what="more periods")
    assert np.allclose(simulator.world.targets, HOME)
    # docs/design.md 6's 0.01 rad
    assert np.abs(np.array(commander.states[-1].position) - HOME).max() < 0.01
    # a partial command moves only the joints it names
    commander.publisher.publish(JointState(name=["arm_1_joint"], position=[0.3]))
    wait_for(lambda: abs(simulator.world.targets[0] - 0.3) < 1e-12, what="partial command")
    assert np.allclose(simulator.world.targets[1:], HOME[1:])


def test_lockstep_commands_of_another_stamp_are_dropped(ros_context, spin):
    """Lockstep: only a command stamped with the current state's stamp (or zero) is applied and
    steps the world; an answer to an older or a later state changes nothing and steps nothing."""
    # steps only when answered: a timeout step would need a minute
    simulator = make_simulator(ros_context, timeout=IN_PROCESS_LOCKSTEP_TIMEOUT_S)
    commander = Commander(ros_context)
    states_matched = publisher_matches(simulator, simulator.state_pub)
    commands_matched = publisher_matches(commander, commander.publisher)
    spin(simulator, commander)
    wait_for(
        lambda: states_matched() and commands_matched(),
        what="the commander and the simulator matched",
    )

    def command(stamp_ns, joint, position):
        msg = JointState(name=[joint], position=[position])
        msg.header.stamp = messages.time_msg(stamp_ns)
        commander.publisher.publish(msg)

    def newest():
        return messages.time_ns(commander.states[-1].header.stamp) if commander.states else -1

    command(0, "arm_3_joint", 0.0)  # zero stamp: answers whatever state is current
    first = wait_for(lambda: max(newest(), 0), what="a step")
    command(first, "arm_3_joint", 0.0)
    wait_for(lambda: newest() == first + 10_000_000, what="the step of an answer")
    current, count = newest(), len(commander.states)
    command(first, "arm_1_joint", 0.3)  # an answer to an older state
    command(current + 10_000_000, "arm_1_joint", 0.3)  # to a state not yet published
    command(current, "arm_2_joint", -0.1)
    wait_for(lambda: newest() == current + 10_000_000, what="the step of the current answer")
    run_periods(commander)
    assert len(commander.states) == count + 1  # nothing else stepped the world
    assert simulator.world.targets[0] == HOME[0] and simulator.world.targets[1] == -0.1
    assert simulator.world.time_ns == current + 10_000_000


def reset_scene(node, situation_msg):
    """The simulator's answer to ~/reset_scene with situation_msg, called from node."""
    return call(
        node, ResetScene, "/simulator/reset_scene", ResetScene.Request(situation=situation_msg)
    )


def test_reset_scene_service_and_latched_situation(ros_context, spin):
    simulator = make_simulator(ros_context, mode="realtime")
    client = Node("test_client", context=ros_context)
    received = []
    client.create_subscription(
        SituationMsg,
        "/situation",
        received.append,
        QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL),
    )
    spin(simulator, client)
    wait_for(lambda: received, what="the latched initial situation")
    box = situations.dataset("box_test")[3]
    response = reset_scene(client, messages.situation_to_msg(box))
    assert response.success, response.message
    assert set(response.objects.names) == {"object", "lid", "lid_edge"}
    wait_for(lambda: received[-1].name == box.name, what="the new situation on /situation")
    bad = messages.situation_to_msg(box)
    bad.task = "juggle"
    response = reset_scene(client, bad)
    assert not response.success and "unknown task" in response.message
    assert simulator.world.situation == box  # untouched
    in_table = messages.situation_to_msg(box)
    in_table.name = "arm_in_table"
    q = HOME.copy()
    q[[1, 3]] = 1.9, 0.5  # the shoulder down: the arm 10 cm inside the table
    in_table.initial_joint_positions = q.tolist()
    response = reset_scene(client, in_table)
    assert not response.success
    assert "the robot's arm_5_link reaches 10.4 cm into the table" in response.message
    assert simulator.world.situation == box


def test_evaluate_and_render_services(ros_context, spin):
    simulator = make_simulator(ros_context, mode="realtime")
    client = spin(simulator, Node("test_client", context=ros_context))[1]
    response = call(client, EvaluateTask, "/simulator/evaluate_task", EvaluateTask.Request())
    assert response.success and response.metrics.task == "grasp"
    assert response.metrics.grasp_cost > 0.25  # the hand is far from the sphere: a miss
    image = call(
        client, RenderScene, "/simulator/render_scene", RenderScene.Request(width=64, height=48)
    ).image
    assert (image.width, image.height, image.encoding) == (64, 48, "rgb8")
    assert len(image.data) == 64 * 48 * 3
    refused = call(
        client, RenderScene, "/simulator/render_scene", RenderScene.Request(width=1, height=48)
    )
    assert not refused.success and "width" in refused.message


def test_perturb_service_moves_the_target_and_refuses_the_impossible(ros_context, spin):
    """~/perturb schedules a target jump and a push in the running episode: /object_poses shows
    the object moved and /joint_states the joint pushed as specified, and /situation carries the
    perturbations; a start already past, or a move into the table, is refused and nothing is
    scheduled."""
    simulator = make_simulator(ros_context, timeout=IN_PROCESS_LOCKSTEP_TIMEOUT_S)
    commander = Commander(ros_context)  # answers nothing yet: the episode holds at its start
    received = []
    commander.create_subscription(
        SituationMsg,
        "/situation",
        received.append,
        QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL),
    )
    spin(simulator, commander)
    sphere = situations.dataset("sphere_test")[1]
    # a reset once the commander is there: it hears the episode's first state
    reset = reset_scene(commander, messages.situation_to_msg(sphere))
    assert reset.success, reset.message
    wait_for(
        lambda: (
            commander.states and commander.states[-1].header.stamp == reset.joint_state.header.stamp
        ),
        what="the episode's first state",
    )
    start = np.array(sphere.object_position)
    jump = Perturbation(kind="move_target", start_s=0.2, duration_s=0.0, offset=[0.05, 0.0, 0.0])
    shove = np.zeros(len(HOME))
    shove[1] = 0.2  # arm_2_joint
    push = Perturbation(kind="push", start_s=0.2, duration_s=0.1, offset=shove.tolist())
    response = call(
        commander, Perturb, "/simulator/perturb", Perturb.Request(perturbations=[jump, push])
    )
    assert response.success, response.message
    wait_for(
        lambda: received and len(received[-1].perturbations) == 2, what="the perturbed situation"
    )
    assert messages.perturbation_from_msg(received[-1].perturbations[0]).offset == (0.05, 0.0, 0.0)
    before = np.array(commander.states[-1].position)
    commander.target = ()  # hold the targets: what the push moved stays moved
    commander.publisher.publish(JointState(header=commander.states[-1].header))
    wait_for(lambda: len(commander.states) > 60, what="60 lockstep periods")
    moved = np.array(messages.object_poses_from_msg(commander.poses[-1])["object"][0]) - start
    assert np.allclose(moved, (0.05, 0.0, 0.0), atol=2e-3)
    pushed = np.array(commander.states[-1].position) - before
    assert pushed[1] == pytest.approx(0.2, abs=0.02)
    assert np.max(np.abs(np.delete(pushed[:7], 1))) < 0.02
    for perturbation, reason in (
        (jump, "starts at 0.2 s, but the episode is at"),
        (
            # the sphere's centre 2 cm above the table top: half its radius into the table
            Perturbation(kind="move_target", start_s=30.0, offset=[0.0, 0.0, 0.02 - start[2]]),
            "into the table",
        ),
        (Perturbation(kind="kick", start_s=30.0), "unknown perturbation kind 'kick'"),
    ):
        response = call(
            commander, Perturb, "/simulator/perturb", Perturb.Request(perturbations=[perturbation])
        )
        assert not response.success and reason in response.message, response.message
    assert len(simulator.world.situation.perturbations) == 2
