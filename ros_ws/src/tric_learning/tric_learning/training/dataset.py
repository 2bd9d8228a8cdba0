"""Demonstrations as arrays: what training reads (paper Sec. 3.2: D = {q_t, y_t, dphi/dq(q_t)}).

A Demo holds one demonstration's samples in time order; a Dataset holds demos of one feature
definition, checked for consistency (same definition, joints and feature sizes, finite values).
Loading from MCAP bags is tric_learning.bags.loader's; this module is plain data. Units: rad, m.
"""

import hashlib
import json
from dataclasses import dataclass, field

import numpy as np

from tric_learning.features import FeatureDefinition
from tric_sim.world.situation import Situation


@dataclass
class Demo:
    """One demonstration of T samples.

    q: (T, n) joint positions, rad. y: (T, d) features. jacobians: (T, d, n) dy/dq.
    object_poses: T dicts {object name: (position, xyzw)} the features were computed with.
    stamps_ns: (T,) simulated time of each sample. metrics: the teacher's outcome (plain dict).
    bag: the file it was read from ("" when it was not read from a bag). robot_profile: the
    identity of the robot profile it was recorded with (RobotProfile.identity; "" when the bag
    predates its record).
    """

    name: str
    situation: Situation
    q: np.ndarray
    y: np.ndarray
    jacobians: np.ndarray
    object_poses: list
    stamps_ns: np.ndarray
    metrics: dict = field(default_factory=dict)
    source: str = ""
    bag: str = ""
    robot_profile: str = ""

    @property
    def length(self) -> int:
        return len(self.q)


@dataclass
class Dataset:
    """Demos of one feature definition (see check())."""

    definition: FeatureDefinition
    demos: list

    def check(self) -> "Dataset":
        """Return self, or ValueError naming the demo and the problem."""
        if not self.demos:
            raise ValueError("the dataset holds no demonstrations")
        n, d = len(self.definition.joint_names), self.definition.size
        for demo in self.demos:
            where = f"demo '{demo.name}'" + (f" (bag {demo.bag})" if demo.bag else "")
            if demo.length < 3:
                raise ValueError(f"{where} has {demo.length} samples; at least 3 are needed")
            for key, shape in (
                ("q", (demo.length, n)),
                ("y", (demo.length, d)),
                ("jacobians", (demo.length, d, n)),
                ("stamps_ns", (demo.length,)),
            ):
                value = np.asarray(getattr(demo, key))
                if value.shape != shape:
                    raise ValueError(f"{where}: {key} has shape {value.shape}, expected {shape}")
                if not np.all(np.isfinite(value)):
                    raise ValueError(f"{where}: {key} has non-finite values")
            if len(demo.object_poses) != demo.length:
                raise ValueError(
                    f"{where}: {len(demo.object_poses)} object poses for {demo.length} samples"
                )
            if np.any(np.diff(demo.stamps_ns) <= 0):
                raise ValueError(f"{where}: sample stamps are not increasing")
        names = [demo.name for demo in self.demos]
        twice = sorted({name for name in names if names.count(name) > 1})
        if twice:
            raise ValueError(f"demonstration names occur twice: {', '.join(twice)}")
        return self

    @property
    def fingerprint(self) -> str:
        """Hex SHA-256 over the definition and every demo's name, situation, arrays and object
        poses: everything a training reads."""
        digest = hashlib.sha256(self.definition.fingerprint.encode())
        for demo in self.demos:
            digest.update(demo.name.encode())
            digest.update(json.dumps(demo.situation.to_dict(), sort_keys=True).encode())
            for array in (demo.q, demo.y, demo.jacobians):
                digest.update(np.ascontiguousarray(array, dtype=np.float64).tobytes())
            for poses in demo.object_poses:
                for name in sorted(poses):
                    digest.update(name.encode())
                    for part in poses[name]:
                        digest.update(np.ascontiguousarray(part, dtype=np.float64).tobytes())
        return digest.hexdigest()

    def subset(self, count: int) -> "Dataset":
        """The first count demos (the N sweeps of Fig. 8)."""
        if not 1 <= count <= len(self.demos):
            raise ValueError(f"a subset of {count} demos from {len(self.demos)} is not possible")
        return Dataset(self.definition, self.demos[:count])
