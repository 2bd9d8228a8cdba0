"""Recording one episode into one MCAP bag (the layout of tric_learning.bags.layout) as its messages
come: the recorder node's core. Samples are taken by recording.EpisodeSampler, one per sample
period of simulated time."""

import json
import pathlib

from sensor_msgs.msg import JointState

from tric_learning import bags
from tric_learning.bags.layout import DEFINITION_TOPIC, SAMPLES_TOPIC, SITUATION_TOPIC, TOPIC_TYPES
from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.messages import definition_msg, sample_msg
from tric_learning.recording import SAMPLE_PERIOD, EpisodeSampler
from tric_learning.scene_recording import SceneTopics
from tric_msgs.msg import ControllerStatus, EpisodeEvent, ObjectPoses
from tric_sim.ros import messages
from tric_sim.viz.scene_view import RobotView
from tric_sim.world.robot_model import RobotModel


class BagRecorder:
    """Writes one episode into one bag (see tric_learning.bags.layout) as its messages come.

    The bag is written to "<path>.part" and renamed to path when the episode's outcome arrives
    (finish()), replacing a bag there only if overwrite; abort() deletes it. Every sample is
    flushed, so a recorder killed mid-episode leaves a readable ".part" with everything up to the
    last sample. A sample is written once a later state shows it is inside the episode: the
    episode's last state (stamped with END, which no command answered) is not a sample, so 5 s at
    125 ms give the paper's T = 40.
    """

    def __init__(
        self,
        path,
        robot: RobotModel,
        situation,
        episode_id: str,
        source: str,
        start_event: EpisodeEvent,
        period: float = SAMPLE_PERIOD,
        status_topic: str = "",
        overwrite: bool = False,
    ):
        """status_topic: also record the controller's status from this topic (empty: none)."""
        self.definition = FeatureDefinition.for_task(situation.task, robot)
        self.sampler = EpisodeSampler(FeatureMap(self.definition, robot), period)
        self.robot = robot
        self.poses: dict = {}
        self.end_ns: int | None = None
        self.latest_state_ns = -1
        self.pending = None
        self.writer = bags.BagWriter(
            path,
            {
                "tric.episode_id": episode_id,
                "tric.source": source,
                "tric.task": situation.task,
                "tric.fingerprint": self.definition.fingerprint,
                "tric.robot_profile": robot.profile.identity,
            },
            overwrite=overwrite,
        )
        for topic, msg_type in TOPIC_TYPES.items():
            self.writer.add_topic(
                topic, msg_type, latched=topic in (DEFINITION_TOPIC, SITUATION_TOPIC)
            )
        start_ns = messages.time_ns(start_event.header.stamp)
        self.start_ns = start_ns
        self.writer.write(DEFINITION_TOPIC, definition_msg(self.definition), start_ns)
        self.writer.write(SITUATION_TOPIC, messages.situation_to_msg(situation), start_ns)
        self.writer.write("/episode", start_event, start_ns)
        self.scene = SceneTopics(self.writer, RobotView(robot), situation, start_ns)
        self.status_topic = status_topic
        if status_topic:
            self.writer.add_topic(status_topic, ControllerStatus)
        self.writer.flush()

    @property
    def path(self) -> pathlib.Path:
        return self.writer.path

    def object_poses(self, msg: ObjectPoses) -> None:
        stamp = messages.time_ns(msg.header.stamp)
        if stamp < self.start_ns or (self.end_ns is not None and stamp > self.end_ns):
            return
        self.poses = messages.object_poses_from_msg(msg)
        self.writer.write("/object_poses", msg, stamp)

    def joint_state(self, msg: JointState) -> bool:
        """Record a joint state of the episode; True if it became a sample."""
        stamp = messages.time_ns(msg.header.stamp)
        if stamp >= self.start_ns:
            self.latest_state_ns = max(self.latest_state_ns, stamp)
        if (
            stamp < self.start_ns
            or (self.end_ns is not None and stamp > self.end_ns)
            or not self.poses
        ):
            return False
        self.writer.write("/joint_states", msg, stamp)
        q = messages.joint_positions_from_msg(msg, self.definition.joint_names)
        self.scene.state(stamp, q, self.poses)
        self._write_pending()
        self.pending = self.sampler.offer(stamp, q, self.poses)
        return self.pending is not None

    def controller_status(self, msg: ControllerStatus) -> None:
        """Record a status of the controller (status_topic) stamped within the episode."""
        stamp = messages.time_ns(msg.header.stamp)
        if stamp >= self.start_ns and (self.end_ns is None or stamp <= self.end_ns):
            self.writer.write(self.status_topic, msg, stamp)

    def _write_pending(self):
        if self.pending is not None:
            if self.end_ns is None or self.pending.stamp_ns < self.end_ns:
                self.writer.write(
                    SAMPLES_TOPIC,
                    sample_msg(self.pending, self.definition.fingerprint),
                    self.pending.stamp_ns,
                )
                self.writer.flush()
            else:
                self.sampler.samples.remove(self.pending)
            self.pending = None

    @property
    def reached_end(self) -> bool:
        """Whether the episode has ended and its last state (stamped at or after END) was seen."""
        return self.end_ns is not None and self.latest_state_ns >= self.end_ns

    def end(self, event: EpisodeEvent) -> None:
        self.end_ns = messages.time_ns(event.header.stamp)
        self._write_pending()
        self.writer.write("/episode", event, self.end_ns)

    def finish(self, outcome: EpisodeEvent = None) -> pathlib.Path:
        """Write the outcome (if any) and close the bag; returns its path."""
        self._write_pending()
        if outcome is not None:
            self.writer.write("/episode", outcome, messages.time_ns(outcome.header.stamp))
            self.writer.set_custom_data(
                "tric.outcome", json.dumps(messages.metrics_dict(outcome.metrics))
            )
        return self.writer.close()

    def abort(self) -> None:
        self.writer.discard()

    def leave_unfinished(self) -> pathlib.Path:
        """Stop recording and leave the bag as its ".part" (an interrupted episode); its path."""
        return self.writer.abandon()
