"""Feature benchmarks: one evaluation of y = phi(q) with its Jacobian dphi/dq
(tric_learning.features.FeatureMap.with_jacobian), as the controller does every tick.

features_us: median wall time of one call for the grasp task (8 landmarks, 224 features) at random
  configurations within the joint limits, the object at a sphere test position, us.
features_box_us: the same for the box-opening task (5 landmarks, 80 features), us.
Target (docs/design.md): features_us <= 100.
"""

import statistics
import sys
import time

import numpy as np

from tric_learning.features import FeatureDefinition, FeatureMap
from tric_sim.world import scene, situations
from tric_sim.world.robot_model import RobotModel

CONFIGURATIONS = 500
ROUNDS = 5


def median_call_us(
    feature_map: FeatureMap, configurations: np.ndarray, object_poses: dict
) -> float:
    """Median wall time of feature_map.with_jacobian over ROUNDS passes of configurations (B, n),
    us."""
    for q in configurations[:50]:  # warm-up
        feature_map.with_jacobian(q, object_poses)
    times = []
    for _ in range(ROUNDS):
        for q in configurations:
            start = time.perf_counter()
            feature_map.with_jacobian(q, object_poses)
            times.append(time.perf_counter() - start)
    return statistics.median(times) * 1e6


def box_object_poses() -> dict:
    """The box and (closed) lid poses of the first box test situation, as the simulator reports
    them: the lid's pose is its hinge frame, lid_edge its lip."""
    box = situations.dataset("box_test")[0]
    hinge = scene.hinge_placement(box)
    return {
        "object": (box.object_position, box.object_orientation),
        "lid": scene.pose_tuple(hinge),
        "lid_edge": scene.pose_tuple(hinge * scene.lid_edge_offset(box.object_dimensions[0])),
    }


def run() -> dict:
    robot = RobotModel()
    configurations = np.random.default_rng(0).uniform(
        robot.lower, robot.upper, (CONFIGURATIONS, robot.n_joints)
    )
    sphere = situations.dataset("sphere_test")[0]
    grasp_poses = {"object": (sphere.object_position, sphere.object_orientation)}
    results = {}
    for key, task, poses in (
        ("features_us", "grasp", grasp_poses),
        ("features_box_us", "open_box", box_object_poses()),
    ):
        feature_map = FeatureMap(FeatureDefinition.for_task(task, robot), robot)
        results[key] = round(median_call_us(feature_map, configurations, poses), 1)
        print(
            f"[bench_features] {task}: {results[key]} us per call (median of "
            f"{ROUNDS * CONFIGURATIONS})",
            file=sys.stderr,
        )
    return results
