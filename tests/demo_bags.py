"""Hand-made demonstration bags for the tests: a few samples of a moving arm, written by the
recorder's BagRecorder, with the outcome a test asks for."""

import math
import pathlib

import numpy as np

from tric_learning.bags.recorder import BagRecorder
from tric_msgs.msg import EpisodeEvent, TaskMetrics
from tric_sim.ros import messages
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

START_NS = 1_000_000_000


def write_demo_bag(
    path: pathlib.Path, robot: RobotModel, situation, outcome="success", episode_id=None
):
    """A short TRIC demonstration bag (5 samples of a moving arm) written by the recorder's
    BagRecorder. outcome: "success", "failure", None (closed without an outcome) or "unfinished"
    (left as a .part file, as by a killed recorder)."""
    episode_id = episode_id or situation.name
    start = EpisodeEvent(
        event=EpisodeEvent.START,
        episode_id=episode_id,
        source="teacher",
        situation=messages.situation_to_msg(situation),
    )
    start.header.stamp = messages.time_msg(START_NS)
    recorder = BagRecorder(path, robot, situation, episode_id, "teacher", start, period=0.02)
    poses = {"object": (situation.object_position, situation.object_orientation)}
    q = robot.home.copy()
    stamp = START_NS
    # a state every 10 ms, a sample every 20 ms: the last state ends the episode
    for k in range(11):
        stamp = START_NS + k * 10_000_000
        q[:3] += 0.01
        recorder.object_poses(messages.object_poses_msg(poses, stamp))
        recorder.joint_state(
            messages.joint_state_msg(robot.joint_names, q, np.zeros(len(q)), stamp)
        )
    end = EpisodeEvent(event=EpisodeEvent.END, episode_id=episode_id, source="teacher")
    end.header.stamp = messages.time_msg(stamp)
    recorder.end(end)
    if outcome == "unfinished":
        recorder.writer._file.close()
        return recorder.writer.part_path
    report = None
    if outcome is not None:
        success = outcome == "success"
        report = EpisodeEvent(
            event=EpisodeEvent.OUTCOME,
            episode_id=episode_id,
            source="teacher",
            metrics=TaskMetrics(
                task="grasp",
                grasp_cost=0.05 if success else 0.6,
                lift_tested=True,
                lift_passed=success,
                lid_angle=math.nan,
                success=success,
                min_distance=0.02,
            ),
        )
        report.header.stamp = messages.time_msg(stamp)
    return recorder.finish(report)


def sphere(name, x=0.6):
    return situations.sphere(name, (x, 0.1, 0.3))
