"""Recording demonstrations: samples every period of simulated time, features and Jacobians, into
one MCAP bag per episode; and reading such bags back into a Dataset.

The recorder node and the offline recorder share EpisodeSampler: given the joint states and object
poses of an episode as they come, it takes one sample per `period` of simulated time (the paper:
every 125 ms of a 5 s demonstration, T = 40) with y = phi(q) and J = dphi/dq.

A bag holds (topic: type):
    /tric/feature_definition: tric_msgs/FeatureDefinition   once, latched
    /tric/situation:          tric_msgs/Situation           once, latched
    /tric/samples:            tric_msgs/FeatureSample       one per sample (q, y, J, object poses)
    /joint_states:            sensor_msgs/JointState        every control period (raw)
    /object_poses:            tric_msgs/ObjectPoses         every control period (raw)
    /episode:                 tric_msgs/EpisodeEvent        START, END, OUTCOME (the teacher's
                                                            metrics)
    /controller/status:       tric_msgs/ControllerStatus    every control tick, when recording a
                                                            controller
and the scene topics for 3D replay (tric_learning.scene_recording: /robot_description, /tf_static,
/tf, /scene_markers), and in its rosbag2 custom data: tric.episode_id, tric.source, tric.task,
tric.fingerprint and, once known, tric.outcome (the metrics as JSON).
"""

import json
import logging
import pathlib
from dataclasses import dataclass

import numpy as np
from sensor_msgs.msg import JointState

from tric_learning import bags
from tric_learning.dataset import Dataset, Demo
from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.messages import definition_from_msg, definition_msg, sample_arrays, sample_msg
from tric_learning.scene_recording import SceneTopics
from tric_msgs.msg import ControllerStatus, EpisodeEvent, FeatureSample, ObjectPoses
from tric_msgs.msg import FeatureDefinition as FeatureDefinitionMsg
from tric_msgs.msg import Situation as SituationMsg
from tric_sim import messages
from tric_sim.robot_model import RobotModel
from tric_sim.scene_view import RobotView

DEFINITION_TOPIC = "/tric/feature_definition"
SITUATION_TOPIC = "/tric/situation"
SAMPLES_TOPIC = "/tric/samples"
TOPIC_TYPES = {
    DEFINITION_TOPIC: FeatureDefinitionMsg,
    SITUATION_TOPIC: SituationMsg,
    SAMPLES_TOPIC: FeatureSample,
    "/joint_states": JointState,
    "/object_poses": ObjectPoses,
    "/episode": EpisodeEvent,
}

#: Default sampling period of demonstrations, s (the paper's 125 ms).
SAMPLE_PERIOD = 0.125
_log = logging.getLogger(__name__)


@dataclass
class Sample:
    """One recorded sample: stamp (ns), step index, q (n,), y (d,), jacobian (d, n), object
    poses."""

    stamp_ns: int
    step: int
    q: np.ndarray
    y: np.ndarray
    jacobian: np.ndarray
    object_poses: dict


class EpisodeSampler:
    """Takes a sample at the episode's first state and then each time `period` of simulated time
    has passed since the previous one."""

    def __init__(self, feature_map: FeatureMap, period: float = SAMPLE_PERIOD):
        if not period > 0:
            raise ValueError("the sampling period must be positive")
        self.features = feature_map
        self.period_ns = int(round(period * 1e9))
        self.samples = []
        self._next_ns = None

    def offer(self, stamp_ns: int, q: np.ndarray, object_poses: dict):
        """A Sample if this state is due, else None."""
        if self._next_ns is not None and stamp_ns < self._next_ns:
            return None
        y, jacobian = self.features.with_jacobian(q, object_poses)
        sample = Sample(
            stamp_ns, len(self.samples), np.array(q, dtype=float), y, jacobian, dict(object_poses)
        )
        self.samples.append(sample)
        start = self.samples[0].stamp_ns
        self._next_ns = start + len(self.samples) * self.period_ns
        return sample


def demo_from_samples(name, situation, samples, metrics=None, source="teacher") -> Demo:
    """A Demo from an episode's samples (in time order)."""
    return Demo(
        name=name,
        situation=situation,
        q=np.array([s.q for s in samples]),
        y=np.array([s.y for s in samples]),
        jacobians=np.array([s.jacobian for s in samples]),
        object_poses=[s.object_poses for s in samples],
        stamps_ns=np.array([s.stamp_ns for s in samples], dtype=np.int64),
        metrics=dict(metrics or {}),
        source=source,
    )


def record_offline(
    robot: RobotModel, situations, duration: float, period: float = SAMPLE_PERIOD, progress=None
) -> Dataset:
    """Demonstrate each situation with its teacher directly on a PhysicsWorld (no ROS) and record
    it: the same samples the recorder node writes to bags. The situations share one task."""
    from tric_sim import metrics
    from tric_sim.physics import PhysicsWorld
    from tric_sim.teachers import demonstrate

    tasks = {s.task for s in situations}
    if len(tasks) != 1:
        raise ValueError(f"the situations mix tasks {sorted(tasks)}")
    definition = FeatureDefinition.for_task(tasks.pop(), robot)
    feature_map = FeatureMap(definition, robot)
    world = PhysicsWorld(robot)
    demos = []
    try:
        for k, situation in enumerate(situations):
            sampler = EpisodeSampler(feature_map, period)

            def observe(w, _teacher, period_index, sampler=sampler):
                q, _ = w.joint_state()
                sampler.offer(period_index * w.control_period_ns, q, w.object_poses())

            world.reset(situation)
            q, _ = world.joint_state()
            sampler.offer(0, q, world.object_poses())
            demonstrate(world, robot, situation, duration, lambda w, t, i: observe(w, t, i + 1))
            outcome = metrics.evaluate(world, robot, run_lift_test=situation.task == "grasp")
            demos.append(
                demo_from_samples(
                    situation.name,
                    situation,
                    sampler.samples[: int(round(duration / period))],
                    {
                        "success": outcome.success,
                        "grasp_cost": outcome.grasp_cost,
                        "lid_angle": outcome.lid_angle,
                    },
                )
            )
            if progress is not None:
                progress(k + 1, len(situations))
    finally:
        world.close()
    return Dataset(definition, demos).check()


class BagRecorder:
    """Writes one episode into one bag (see the module docstring) as its messages come.

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
        self.poses = {}
        self.end_ns = None
        self.latest_state_ns = -1
        self.pending = None
        self.writer = bags.BagWriter(
            path,
            {
                "tric.episode_id": episode_id,
                "tric.source": source,
                "tric.task": situation.task,
                "tric.fingerprint": self.definition.fingerprint,
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


def bag_paths(paths, tolerant: bool = False, notice=None) -> list:
    """The bags among paths: files, or folders whose *.mcap files are taken in name order; with
    tolerant, a folder's unfinished *.mcap.part files too. Each .part file left out is named through
    notice(text) (default: logged as a warning). ValueError for a path that does not exist or
    holds no bag."""
    notice = notice or _log.warning
    found = []
    for path in map(pathlib.Path, paths):
        if path.is_dir():
            inside = sorted(path.glob("*" + bags.BAG_SUFFIX))
            unfinished = sorted(path.glob("*" + bags.BAG_SUFFIX + bags.PART_SUFFIX))
            if tolerant:
                inside = sorted(inside + unfinished)
            else:
                for part in unfinished:
                    notice(
                        f"skipped {part}: an unfinished recording (tric-train --tolerant reads it)"
                    )
            if not inside:
                raise ValueError(
                    f"{path} holds no {bags.BAG_SUFFIX} bags"
                    + (f" (only {len(unfinished)} unfinished .part files)" if unfinished else "")
                )
            found += inside
        elif path.is_file():
            found.append(path)
        else:
            raise ValueError(f"{path} does not exist")
    if not found:
        raise ValueError("no bags given")
    return found


def load_dataset(
    paths,
    robot: RobotModel = None,
    progress=None,
    *,
    include_failed: bool = False,
    tolerant: bool = False,
    notice=None,
) -> Dataset:
    """A Dataset of the demonstrations in the bags at paths (see bag_paths). Every bag must be a
    TRIC recording of the same feature definition, on this robot, of a demonstration that succeeded
    by its recorded outcome (include_failed: of any outcome, or none); anything else is refused
    with a ValueError that names the bags and the problem. tolerant: unfinished and damaged bags
    are read up to their damage instead of refused. Bags skipped, read tolerantly or taken despite
    their outcome are named through notice(text) (default: logged as a warning). progress(done,
    total) after each bag."""
    notice = notice or _log.warning
    files = bag_paths(paths, tolerant, notice)
    definition, demos, failed, origin = None, [], [], {}
    for k, path in enumerate(files):
        demo, bag_definition = _load_demo(path, tolerant, notice)
        if definition is None:
            definition = bag_definition
            if robot is not None:
                try:
                    FeatureDefinition.for_task(definition.task, robot).check_same(
                        definition, f"bag {path}"
                    )
                except ValueError as error:
                    raise ValueError(
                        f"{error} (recorded with another robot model or definition)"
                    ) from None
        else:
            try:
                definition.check_same(bag_definition, f"bag {path}")
            except ValueError as error:
                raise ValueError(f"{error}; the first bag was {files[0]}") from None
        if demo.name in origin:
            raise ValueError(
                f"bags {origin[demo.name]} and {path} both hold the demonstration '{demo.name}' "
                "(recorded twice into one folder?); give only one of them"
            )
        origin[demo.name] = path
        outcome = _outcome_problem(demo.metrics)
        if outcome:
            failed.append(f"{path} ({outcome})")
        demos.append(demo)
        if progress is not None:
            progress(k + 1, len(files))
    if failed and not include_failed:
        raise ValueError(
            f"{len(failed)} of {len(files)} bags are not successful demonstrations: "
            f"{'; '.join(failed)}. Leave them out, or include them on purpose "
            "(tric-train --include-failed)"
        )
    for entry in failed:
        notice(f"included {entry}, as include_failed asks")
    try:
        return Dataset(definition, demos).check()
    except ValueError as error:
        raise ValueError(f"the bags do not make a dataset: {error}") from None


def _outcome_problem(metrics: dict) -> str:
    """Why a demonstration's recorded outcome (its metrics) is not a success; "" when it is one."""
    if not metrics:
        return "no recorded outcome"
    if metrics.get("success") is True:
        return ""
    details = [
        f"{key.replace('_', ' ')} {metrics[key]:.3g}"
        for key in ("grasp_cost", "lid_angle")
        if isinstance(metrics.get(key), (int, float)) and not isinstance(metrics.get(key), bool)
    ]
    return "failed" + (f": {', '.join(details)}" if details else "")


def _load_demo(path: pathlib.Path, tolerant: bool = False, notice=None):
    info = bags.bag_info(path, tolerant=tolerant)
    if not info.complete and notice is not None:
        notice(f"reading {path} up to its end or damage: it is not a finished bag")
    if SAMPLES_TOPIC not in info.topics or DEFINITION_TOPIC not in info.topics:
        raise ValueError(
            f"bag {path} is not a TRIC demonstration (no {SAMPLES_TOPIC} or {DEFINITION_TOPIC})"
        )
    definition = situation = None
    samples, metrics, source = [], {}, info.custom_data.get("tric.source", "")
    expected = {
        DEFINITION_TOPIC: FeatureDefinitionMsg,
        SITUATION_TOPIC: SituationMsg,
        SAMPLES_TOPIC: FeatureSample,
        "/episode": EpisodeEvent,
    }
    try:
        for message in bags.read_bag(
            path, topics=list(expected), expected_types=expected, tolerant=tolerant
        ):
            if message.topic == DEFINITION_TOPIC:
                definition = definition_from_msg(message.message)
            elif message.topic == SITUATION_TOPIC:
                situation = messages.situation_from_msg(message.message)
            elif message.topic == SAMPLES_TOPIC:
                if definition is None:
                    raise ValueError("a sample before the feature definition")
                samples.append(sample_arrays(message.message, definition))
            elif message.message.event == EpisodeEvent.OUTCOME:
                metrics = messages.metrics_dict(message.message.metrics)
    except ValueError as error:
        text = str(error)
        raise ValueError(text if str(path) in text else f"bag {path}: {text}") from None
    if situation is None:
        raise ValueError(f"bag {path} has no situation")
    if len(samples) < 3:
        raise ValueError(f"bag {path} has {len(samples)} samples; a demonstration needs at least 3")
    stamps, qs, ys, jacobians, poses = zip(*samples)
    name = info.custom_data.get("tric.episode_id", path.stem)
    if not metrics and "tric.outcome" in info.custom_data:
        try:
            metrics = json.loads(info.custom_data["tric.outcome"])
        except json.JSONDecodeError:
            raise ValueError(f"bag {path}: its recorded outcome is not JSON") from None
        if not isinstance(metrics, dict):
            raise ValueError(f"bag {path}: its recorded outcome is not a mapping")
    demo = Demo(
        name=name,
        situation=situation,
        q=np.array(qs),
        y=np.array(ys),
        jacobians=np.array(jacobians),
        object_poses=list(poses),
        stamps_ns=np.array(stamps, dtype=np.int64),
        metrics=metrics,
        source=source,
        bag=str(path),
    )
    return demo, definition
