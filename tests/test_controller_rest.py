"""The controller node's tick at rest: a runner's steps that hold for stale input, close the grip
and then keep the hand at rest are told apart, and the runner's end of an episode at rest (its
min_steps done, or its budget spent) ends the node's episode too (it once ended only while the
grip was closing, so an episode asked to run past its grip never ended through the nodes)."""

import types

import numpy as np
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy

from conftest import wait_for
from tric_control.controller_node import ControllerNode
from tric_control.episode_runner import EpisodeStats, Step
from tric_msgs.msg import ControllerStatus

KEEP_ALL = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)


class ScriptedRunner:
    """Stands in for an EpisodeRunner: returns the scripted steps in turn, counting the ones that
    are not stale holds as the runner counts its steps."""

    def __init__(self, steps):
        self.script = list(steps)
        self.stats = EpisodeStats()

    def step(self, q, poses, stamp_ns=None, now_ns=None) -> Step:
        decided = self.script.pop(0)
        self.stats.steps += not decided.held
        return decided


def test_at_rest_past_the_grip_the_runner_s_outcome_ends_the_episode(ros_context, spin):
    controller = ControllerNode(context=ros_context)
    statuses: list = []
    observer = Node("rest_observer", context=ros_context)
    observer.create_subscription(ControllerStatus, "/controller/status", statuses.append, KEEP_ALL)
    spin(controller, observer)
    command = np.zeros(len(controller.robot.joint_names))
    converged = ("converged", "at rest after 120 steps, then gripped for 30")
    runner = ScriptedRunner(
        [
            Step(command, held="a stale state"),
            Step(command, gripping=True),
            Step(command),  # at rest, gripped, min_steps not done yet
            Step(command, outcome=converged),  # at rest, min_steps done
        ]
    )
    model = types.SimpleNamespace(kind="tric", path="scripted.safetensors", objective=None)
    episode = types.SimpleNamespace(
        start_ns=None, last_ns=None, runner=runner, model=model, steps=0
    )
    controller._event = lambda kind, episode: None  # no goal behind this episode
    outcomes = [
        controller._tick(episode, stamp, command, {}, stamp, stamp)
        for stamp in (10_000_000, 20_000_000, 30_000_000, 40_000_000)
    ]
    assert outcomes == [None, None, None, converged]
    wait_for(lambda: len(statuses) >= 4, what="four statuses")
    assert [s.state for s in statuses[:4]] == [
        ControllerStatus.HOLDING,
        ControllerStatus.GRIPPING,
        ControllerStatus.CONVERGED,
        ControllerStatus.CONVERGED,
    ]
    assert episode.last_ns == 40_000_000  # the stale hold answered nothing; the rest did
