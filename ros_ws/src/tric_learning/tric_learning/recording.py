"""Recording demonstrations: one sample every period of simulated time, with its features and
Jacobians, and the offline recorder that demonstrates situations on a PhysicsWorld without ROS.

The recorder node (through tric_learning.bags.recorder) and the offline recorder share
EpisodeSampler: given the joint states and object poses of an episode as they come, it takes one
sample per `period` of simulated time (the paper: every 125 ms of a 5 s demonstration, T = 40) with
y = phi(q) and J = dphi/dq. Bags are written by tric_learning.bags.recorder and read back by
tric_learning.bags.loader.
"""

from dataclasses import dataclass

import numpy as np

from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.training.dataset import Dataset, Demo
from tric_sim.world.robot_model import RobotModel

#: Default sampling period of demonstrations, s (the paper's 125 ms).
SAMPLE_PERIOD = 0.125


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
        self.samples: list[Sample] = []
        self._next_ns: int | None = None

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
    from tric_sim.physics import metrics
    from tric_sim.physics.simulation import PhysicsWorld
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
