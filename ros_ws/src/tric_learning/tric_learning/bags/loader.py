"""Reading demonstration bags (the layout of tric_learning.bags.layout) back into a Dataset: which
files the paths name (bag_paths), and every bag checked, by its feature definition, robot and
recorded outcome, before it joins the dataset (load_dataset)."""

import logging
import pathlib
from typing import cast

import numpy as np

from tric_learning import bags
from tric_learning.bags.layout import DEFINITION_TOPIC, SAMPLES_TOPIC, SITUATION_TOPIC
from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.messages import definition_from_msg, sample_arrays
from tric_learning.training.dataset import Dataset, Demo
from tric_msgs.msg import EpisodeEvent, FeatureSample
from tric_msgs.msg import FeatureDefinition as FeatureDefinitionMsg
from tric_msgs.msg import Situation as SituationMsg
from tric_sim.ros import messages
from tric_sim.tools.untrusted import load_data
from tric_sim.world.robot_model import RobotModel

_log = logging.getLogger(__name__)

#: The most a bag's recorded feature or Jacobian entry may differ from FeatureMap's on the bag's own
#: q and object poses (m, or m/rad): far above rounding, far below any change of the features.
FEATURE_TOLERANCE = 1e-9


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
    robot: RobotModel | None = None,
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
    total) after each bag. With a robot, each bag's recorded y and dphi/dq must be today's
    FeatureMap on its own q and object poses (check_features), and a bag recorded with another
    version of the robot's profile is named through notice."""
    notice = notice or _log.warning
    files = bag_paths(paths, tolerant, notice)
    origin: dict[str, pathlib.Path]
    definition, demos, failed, origin, feature_map = None, [], [], {}, None
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
                feature_map = FeatureMap(definition, robot)
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
        if feature_map is not None:
            check_features(demo, feature_map)
        if robot is not None and (change := robot.profile.change_since(demo.robot_profile, path)):
            notice(change)
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
        # bag_paths gives at least one bag, whose definition this is
        return Dataset(cast(FeatureDefinition, definition), demos).check()
    except ValueError as error:
        raise ValueError(f"the bags do not make a dataset: {error}") from None


def check_features(demo: Demo, feature_map: FeatureMap) -> None:
    """ValueError naming the demo's bag if a recorded feature vector y or Jacobian dphi/dq differs
    by more than FEATURE_TOLERANCE from feature_map's on the recorded q and object poses (the bag
    was recorded by other feature code, or edited): training on it would mix two definitions."""
    for t, (q, poses) in enumerate(zip(demo.q, demo.object_poses)):
        y, jacobian = feature_map.with_jacobian(q, poses)
        off_y, off_jacobian = (
            np.abs(y - demo.y[t]).max(),
            np.abs(jacobian - demo.jacobians[t]).max(),
        )
        if not (off_y <= FEATURE_TOLERANCE and off_jacobian <= FEATURE_TOLERANCE):
            raise ValueError(
                f"bag {demo.bag or demo.name}: its recorded features differ from today's on its "
                f"own q at sample {t} (y by {off_y:.3g}, dphi/dq by {off_jacobian:.3g}): it was "
                "recorded by other feature code; record it again (tric-record)"
            )


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
            path,
            topics=list(expected),
            expected_types=expected,
            optional_fields=messages.LATER_FIELDS,
            tolerant=tolerant,
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
        metrics = load_data(
            info.custom_data["tric.outcome"], f"bag {path}: its recorded outcome", json_format=True
        )
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
        robot_profile=info.custom_data.get("tric.robot_profile", ""),
    )
    return demo, definition
