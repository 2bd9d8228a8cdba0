"""The recorder node: one MCAP bag per episode, with features and Jacobians
(tric_learning.bags.recorder).

Listens to /episode (tric_msgs/EpisodeEvent): on START from a recorded source it opens
`<output_dir>/<episode_id>.mcap.part`; it then writes every /joint_states and /object_poses of the
episode and, every `sample_period_s` of simulated time, a tric_msgs/FeatureSample with
y = phi(q) and dphi/dq; on END it stops, on OUTCOME (or after `outcome_timeout_s` without one) it
writes the outcome and renames the bag to `<episode_id>.mcap`; on ABORT it deletes it. Events,
states and poses are read by one thread of the node's own and applied in the order of their stamps,
so that an END is never overtaken by the states that follow it (a lift test's), and a bag is closed
only once that thread has seen the episode's last state (or `outcome_timeout_s` passed).

Each bag also carries the scene for 3D replay in Foxglove (/robot_description, /tf_static, /tf,
/scene_markers: tric_learning.scene_recording) and, when `status_topic` is set, the controller's
status of every tick.

Parameters (checked at startup: a bad one ends the node with exit status 2): output_dir
("recordings": a folder that can be written, created if missing), sample_period_s (0.125, > 0),
sources (["teacher"]: the episode sources to record), outcome_timeout_s (30, > 0), overwrite (false:
an episode whose bag name is taken is written to <name>_1.mcap, ..., and a bag that appears under
its name while it records is kept too; true: its new bag replaces the old one when it is finished),
status_topic ("": none; "/controller/status" to record a controller's episodes with their status).
A bag's .part is held under an exclusive lock while it is written (another recorder writing the
same one is refused: the episode is not recorded, naming that recorder's PID).
"""

import pathlib
import sys
import threading
import time
from collections import deque

from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import JointState

from tric_learning import bags
from tric_learning.bags.recorder import BagRecorder
from tric_learning.recording import SAMPLE_PERIOD
from tric_msgs.msg import ControllerStatus, EpisodeEvent, ObjectPoses
from tric_sim.ros import messages
from tric_sim.ros.graph import EVENT_QOS, run_node
from tric_sim.ros.parameters import POSITIVE, declare, declare_robot
from tric_sim.ros.topic_poller import TopicPoller
from tric_sim.tools.file_names import safe_stem
from tric_sim.tools.output_files import check_output_folder

#: The recorded state topics: deep enough to hold a whole 5 s episode at 100 Hz should the
#: recording thread fall behind.
RECORDED_STATE_QOS = QoSProfile(depth=1000, reliability=ReliabilityPolicy.RELIABLE)
#: States kept from before an episode's START (its first states may arrive before the event).
BACKLOG = 20


class RecorderNode(Node):
    """Records episodes to bags (see the module docstring). `finished` lists the bags written,
    `failed` the (episode id, reason) of episodes that could not be recorded; `changed`, a
    threading.Condition, is notified whenever they or `busy` may have changed (wait on it to
    follow the recorder from another thread)."""

    def __init__(self, **kwargs):
        super().__init__("recorder", **kwargs)
        self.output_dir = check_output_folder(
            declare(self, "output_dir", "recordings", "folder the bags are written to"),
            "parameter output_dir",
        )
        self.period = declare(
            self, "sample_period_s", SAMPLE_PERIOD, "simulated seconds between samples", POSITIVE
        )
        self.sources = declare(self, "sources", ["teacher"], "episode sources to record")
        self.outcome_timeout = declare(
            self,
            "outcome_timeout_s",
            30.0,
            "wall seconds to wait for an ended episode's outcome",
            POSITIVE,
        )
        self.overwrite = declare(
            self,
            "overwrite",
            False,
            "replace a bag of the same name (false: add a numbered copy beside it)",
        )
        self.status_topic = declare(
            self, "status_topic", "", "the controller's status topic to record (empty: none)"
        )
        self.robot = declare_robot(self)
        self.finished = []
        self.failed = []
        self._lock = threading.Lock()
        self.changed = threading.Condition(self._lock)
        self._recorder = None
        self._ended_at = None
        self._outcome = None
        self._backlog = deque(maxlen=BACKLOG)
        self._stop = threading.Event()
        streams = {
            "state": (JointState, "/joint_states", RECORDED_STATE_QOS),
            "poses": (ObjectPoses, "/object_poses", RECORDED_STATE_QOS),
            "event": (EpisodeEvent, "/episode", EVENT_QOS),
        }
        if self.status_topic:
            streams["status"] = (ControllerStatus, self.status_topic, RECORDED_STATE_QOS)
        self._poller = TopicPoller(self.context, "recorder_streams", streams)
        self._thread = threading.Thread(target=self._stream, daemon=True, name="recorder_streams")
        self._thread.start()
        self.create_timer(1.0, self._check_outcome_timeout)
        self.get_logger().info(
            f"recording episodes of {', '.join(self.sources)} to {self.output_dir}/"
        )

    def destroy_node(self):
        self._stop.set()
        self._thread.join()
        self._poller.destroy()
        with self._lock:
            if self._recorder is not None:  # shut down mid-episode: the bag stays unfinished
                path = self._recorder.leave_unfinished()
                self._recorder = None
                self._failed(self._episode_id, f"interrupted; left unfinished as {path}")
            self.changed.notify_all()
        return super().destroy_node()

    @property
    def busy(self) -> bool:
        """Whether an episode's bag is open."""
        return self._recorder is not None

    def _stream(self):
        """The recording thread: events and states in the order of their stamps (at one stamp:
        START, poses, state, then END, OUTCOME or ABORT), so that an episode's END is applied before
        the states that follow it (a lift test's, the next scene's)."""
        while not self._stop.is_set() and self.context.ok():
            received = self._poller.poll(0.05)
            batch = [
                (messages.time_ns(msg.header.stamp), _order(kind, msg), k, kind, msg)
                for kind, msgs in received.items()
                for k, msg in enumerate(msgs)
            ]
            if not batch:
                continue
            with self._lock:
                try:
                    self._apply(batch)
                except OSError as error:  # a full disk, a folder removed: this episode is lost
                    self._lose_episode(f"its bag could not be written: {error}")
                self.changed.notify_all()

    def _apply(self, batch):
        """Apply a batch of (stamp, order, k, kind, msg) in order (holding the lock)."""
        for _, _, _, kind, msg in sorted(batch, key=lambda entry: entry[:3]):
            if kind == "event":
                self._on_event(msg)
                continue
            self._backlog.append((kind, msg))
            if self._recorder is not None:
                self._write(kind, msg)
        if self._outcome is not None and self._recorder.reached_end:
            self._close(self._outcome)

    def _lose_episode(self, reason: str):
        """Discard the bag being recorded (its .part removed: the space it took freed) and name
        the episode as not recorded; the recorder goes on with the next episode."""
        recorder, self._recorder, self._outcome = self._recorder, None, None
        if recorder is None:
            return
        try:
            recorder.abort()
        except OSError:
            pass
        self._failed(self._episode_id, reason)

    def _write(self, kind, msg):
        try:
            if kind == "poses":
                self._recorder.object_poses(msg)
            elif kind == "status":
                self._recorder.controller_status(msg)
            else:
                self._recorder.joint_state(msg)
        except ValueError as error:
            self.get_logger().warning(
                f"skipped a malformed {kind} message: {error}", throttle_duration_sec=1.0
            )

    def _on_event(self, event: EpisodeEvent):
        """Apply an episode event (called by the recording thread, holding the lock)."""
        if event.event == EpisodeEvent.START:
            if event.source not in self.sources:
                return
            if self._recorder is not None:
                self.get_logger().warning(
                    f"episode '{event.episode_id}' started before the previous one "
                    "finished; closing the previous bag"
                )
                self._close(None)
            self._start(event)
        elif self._recorder is None or event.episode_id != self._episode_id:
            return
        elif event.event == EpisodeEvent.END:
            self._recorder.end(event)
            self._ended_at = time.monotonic()
        elif event.event == EpisodeEvent.OUTCOME:
            self._outcome = event
            if self._recorder.reached_end:
                self._close(event)
        elif event.event == EpisodeEvent.ABORT:
            self._recorder.abort()
            self.get_logger().info(f"episode '{event.episode_id}' aborted: bag discarded")
            self._recorder = None

    def _start(self, event):
        try:
            situation = messages.situation_from_msg(event.situation, self.robot.n_joints)
            path = self._free_path(event.episode_id or situation.name)
            self._recorder = BagRecorder(
                path,
                self.robot,
                situation,
                event.episode_id,
                event.source,
                event,
                self.period,
                self.status_topic,
                overwrite=self.overwrite,
            )
        except (ValueError, OSError) as error:
            self._failed(event.episode_id, str(error))
            return
        self._episode_id = event.episode_id
        self._ended_at = None
        self._outcome = None
        for kind, msg in list(self._backlog):  # the episode's first states may have come first
            self._write(kind, msg)

    def _free_path(self, name: str) -> pathlib.Path:
        """The bag path for an episode name: <name>.mcap, or with overwrite false and that name
        taken, the first free <name>_<k>.mcap."""
        safe = safe_stem(name)
        path, k = self.output_dir / f"{safe}{bags.BAG_SUFFIX}", 1
        while not self.overwrite and (
            path.exists() or path.with_name(path.name + bags.PART_SUFFIX).exists()
        ):
            path, k = self.output_dir / f"{safe}_{k}{bags.BAG_SUFFIX}", k + 1
        return path

    def _close(self, outcome):
        recorder, self._recorder, self._outcome = self._recorder, None, None
        try:
            path = recorder.finish(outcome)
        except OSError as error:
            recorder.abort()
            self._failed(self._episode_id, f"its bag could not be finished: {error}")
            return
        self.finished.append(path)
        self.get_logger().info(f"wrote {path} ({len(recorder.sampler.samples)} samples)")

    def _failed(self, episode_id: str, reason: str):
        """An episode that could not be recorded: logged and kept in `failed` as (episode id,
        reason)."""
        self.failed.append((episode_id, reason))
        self.get_logger().error(f"episode '{episode_id}' not recorded: {reason}")

    def _check_outcome_timeout(self):
        with self._lock:
            if (
                self._recorder is not None
                and self._ended_at is not None
                and time.monotonic() - self._ended_at > self.outcome_timeout
            ):
                if self._outcome is None:
                    self.get_logger().warning(
                        f"no outcome for '{self._episode_id}' within "
                        f"{self.outcome_timeout:g} s: closing its bag without one"
                    )
                else:
                    self.get_logger().warning(
                        f"the last state of '{self._episode_id}' never arrived: "
                        "closing its bag with the states it has"
                    )
                self._close(self._outcome)
                self.changed.notify_all()


def _order(kind: str, msg) -> int:
    """Rank of a message among those of the same stamp (see RecorderNode._stream)."""
    if kind == "event":
        return 0 if msg.event == EpisodeEvent.START else 3
    return 1 if kind == "poses" else 2


def main(args=None):
    return run_node(RecorderNode, "recorder", args)


if __name__ == "__main__":
    sys.exit(main())
