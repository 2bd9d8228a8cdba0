"""Where the grasp teacher's palm approaches an object from: the approach direction for a sphere,
the grasp point and direction across a cylinder's axis, both chosen so that the wrist ends a
comfortable distance from the shoulder (the robot profile's grasp_teacher settings: shoulder,
palm_to_wrist, wrist_distance; for the paper's robot, the arm_2 joint, the arm_6 joint and an
elbow angle well conditioned across the workspace), and the palm frame built on a direction.
Units: m, rad."""

import math

import numpy as np

from tric_sim.world.profile_entries import GraspTeacherSettings


def _wrist_discomfort(point: np.ndarray, n: np.ndarray, reach: GraspTeacherSettings) -> float:
    """How far the wrist would be from its comfortable distance to the shoulder, m, when the palm
    approaches point along n."""
    wrist = point - n * (0.06 + reach.palm_to_wrist)
    return abs(float(np.linalg.norm(wrist - np.array(reach.shoulder))) - reach.wrist_distance)


def approach_direction(centre: np.ndarray, reach: GraspTeacherSettings) -> np.ndarray:
    """Unit vector along which the palm approaches a sphere centred at centre (world): pointing away
    from the robot in azimuth, tilted down so the wrist ends its comfortable distance from the
    shoulder."""
    azimuth = math.atan2(centre[1], centre[0])
    candidates = [
        np.array([math.cos(t) * math.cos(azimuth), math.cos(t) * math.sin(azimuth), -math.sin(t)])
        for t in np.radians(np.arange(10.0, 81.0, 1.0))
    ]
    return min(candidates, key=lambda n: _wrist_discomfort(centre, n, reach))


#: A cylinder's approach from the robot's left (+y) costs this much more per unit of y, m: an
#: upright cylinder in front of the robot has two mirror approaches of equal comfort, and the
#: demonstrations should not flip between them (docs/decisions/cylinder-teacher.md).
SIDE_PREFERENCE = 0.02


def cylinder_grasp_point(
    centre: np.ndarray, axis: np.ndarray, height: float, reach: GraspTeacherSettings
):
    """(point on the axis, approach direction across the axis) for a cylinder: the direction points
    away from the robot and not upwards, the point lies within the middle of the cylinder, and the
    pair puts the wrist closest to its comfortable distance from the shoulder. Away means a
    horizontal component away from the robot of reach.cylinder_min_outward at least; a cylinder
    whose axis points at the robot has no such direction across it: then the direction may point
    across (down onto the cylinder, or sideways)."""
    e1 = np.cross(axis, [0.0, 0.0, 1.0])
    if np.linalg.norm(e1) < 1e-6:
        e1 = np.cross(axis, [1.0, 0.0, 0.0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    outward = np.array([centre[0], centre[1], 0.0]) / np.linalg.norm(centre[:2])
    best, best_cost = None, math.inf
    for least_outward in (reach.cylinder_min_outward, min(reach.cylinder_min_outward, -0.2)):
        for offset in np.linspace(-0.3, 0.3, 7) * height:
            point = centre + offset * axis
            for angle in np.radians(np.arange(0.0, 360.0, 5.0)):
                n = math.cos(angle) * e1 + math.sin(angle) * e2
                if n @ outward < least_outward or n[2] > 0.1:
                    continue
                cost = (
                    _wrist_discomfort(point, n, reach)
                    + 0.05 * abs(offset) / height
                    + SIDE_PREFERENCE * max(float(n[1]), 0.0)
                )
                if cost < best_cost:
                    best, best_cost = (point, n), cost
        if best is not None:
            return best
    raise ValueError("no direction across the cylinder's axis points away from the robot or down")


def frame_from(normal: np.ndarray, x_hint: np.ndarray) -> np.ndarray:
    """Rotation with z = normal and x as close to x_hint as possible (orthogonalized)."""
    z = normal / np.linalg.norm(normal)
    x = x_hint - (x_hint @ z) * z
    if np.linalg.norm(x) < 1e-6:
        x = np.cross(z, [0.0, 1.0, 0.0] if abs(z[1]) < 0.9 else [1.0, 0.0, 0.0])
    x /= np.linalg.norm(x)
    return np.column_stack([x, np.cross(z, x), z])
