"""A candidate's rollouts from its demonstrations' starts: the evaluation's episode (offline, the
controller core on PhysicsWorld, tric_control.evaluation.offline) from each demonstration's start
situation, with the state it ended in, for the selection scores (tric_control.selection.scores).
ROS-free. Units: rad, m.

The hidden metrics judge each rollout too, after its end state is taken: a reference that a
model's provenance reports beside its score, and that the judge-based scores (never the default)
read. A training's selection leaves a grasp's lift test out (its success is then the grasp cost's
alone, lift_passed None) unless its score reads it: the test costs a sixth of a rollout, and the
end state is taken before it."""

import math
from dataclasses import asdict, dataclass

import numpy as np

from tric_control.evaluation.offline import OfflineEvaluator
from tric_learning.features import FeatureMap
from tric_learning.training.dataset import Dataset


@dataclass
class Rollout:
    """One rollout of a candidate from a demonstration's start situation.

    demo: the demonstration's name. q: (n,) joint positions at the end, rad. y: (d,) features at
    the end. value_start, value_end: f at the first and last control tick. steps: control ticks.
    outcome: how the episode ended ("converged", "step_budget", "failed"). judged: the hidden
    metrics' verdict, for reference only: success, grasp_cost, lift_passed, lid_angle (NaN or None
    where they do not apply).
    """

    demo: str
    q: np.ndarray
    y: np.ndarray
    value_start: float
    value_end: float
    steps: int
    outcome: str
    judged: dict

    @property
    def failed(self) -> bool:
        """The episode could not be run to its end (its controller failed)."""
        return self.outcome == "failed"

    def to_dict(self) -> dict:
        """JSON-compatible: arrays as lists, NaN as None."""
        data = asdict(self)
        data["q"], data["y"] = self.q.tolist(), self.y.tolist()
        for key in ("value_start", "value_end"):
            data[key] = None if not math.isfinite(data[key]) else data[key]
        data["judged"] = {
            k: (None if isinstance(v, float) and not math.isfinite(v) else v)
            for k, v in self.judged.items()
        }
        return data


def roll_out(evaluator: OfflineEvaluator, dataset: Dataset) -> list:
    """[Rollout] of evaluator's model from the start situation of every demonstration of dataset,
    in the dataset's order."""
    feature_map = FeatureMap(dataset.definition, evaluator.robot)
    return [_rollout(evaluator, demo, feature_map) for demo in dataset.demos]


def _rollout(evaluator: OfflineEvaluator, demo, feature_map: FeatureMap) -> Rollout:
    end: dict = {}

    def on_period(world, decided):
        if decided is not None and decided.tick is not None:
            end.setdefault("value_start", float(decided.tick.value))
            end["value_end"] = float(decided.tick.value)
        end["q"], _ = world.joint_state()
        end["poses"] = world.object_poses()

    record = evaluator.run(demo.situation, on_period=on_period)
    if "q" in end:
        q = np.array(end["q"], dtype=float)
        y = feature_map(q, end["poses"])
    else:  # the controller failed before its first period
        q = np.full(len(demo.q[0]), math.nan)
        y = np.full(len(demo.y[0]), math.nan)
    return Rollout(
        demo=demo.name,
        q=q,
        y=y,
        value_start=end.get("value_start", math.nan),
        value_end=end.get("value_end", math.nan),
        steps=record.steps,
        outcome=record.outcome,
        judged={
            "success": record.success,
            "grasp_cost": record.grasp_cost,
            "lift_passed": record.lift_passed,
            "lid_angle": record.lid_angle,
            "failure": record.failure,
        },
    )
