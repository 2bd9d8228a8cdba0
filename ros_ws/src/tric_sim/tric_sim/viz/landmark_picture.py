"""A picture of a robot's landmarks (tric-robot-check --picture): the robot at its start, rendered
by PyBullet's software renderer, seen from beside its hand, with each landmark frame of its profile
marked and named, written atomically as a PNG file."""

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from tric_sim.physics.profile_check import landmark_frames  # noqa: E402
from tric_sim.physics.simulation import PhysicsWorld  # noqa: E402
from tric_sim.tools.output_files import atomic_path  # noqa: E402
from tric_sim.world import situations  # noqa: E402
from tric_sim.world.robot_model import RobotModel  # noqa: E402

#: Where the camera looks from, relative to the palm at the start (world axes), m; its field of
#: view, degrees.
EYE_OFFSET = np.array([0.30, -0.45, 0.20])
FOV_DEG = 40.0


def pixels(points: np.ndarray, eye, target, fov_deg: float, size) -> np.ndarray:
    """Where world points (k, 3) appear in an image of size (width, height) of a pinhole camera at
    eye looking at target, z up (PyBullet's computeViewMatrix and computeProjectionMatrixFOV, the
    vertical field of view fov_deg): (k, 2) pixel columns and rows."""
    forward = np.asarray(target, float) - np.asarray(eye, float)
    forward /= np.linalg.norm(forward)
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    relative = np.asarray(points, float) - np.asarray(eye, float)
    depth = relative @ forward
    focal = 0.5 * size[1] / np.tan(np.radians(fov_deg) / 2)
    columns = 0.5 * size[0] + focal * (relative @ right) / depth
    rows = 0.5 * size[1] - focal * (relative @ up) / depth
    return np.column_stack([columns, rows])


def write_landmark_picture(robot: RobotModel, path: pathlib.Path, size=(800, 600)) -> None:
    """Render the robot at its start with its landmark frames marked and named, to path (PNG)."""
    world = PhysicsWorld(robot)
    try:
        world.reset(situations.sphere("landmarks", (0.6, 0.0, 0.1)))
        robot.forward(robot.home)
        frames = landmark_frames(robot)
        points = np.array([robot.frame_placement(f).translation for f in frames])
        target = robot.frame_placement(robot.profile.palm).translation
        eye = target + EYE_OFFSET
        image = world.render(size[0], size[1], eye.tolist(), target.tolist(), FOV_DEG)
    finally:
        world.close()
    where = pixels(points, eye, target, FOV_DEG, size)
    figure, axis = plt.subplots(figsize=(size[0] / 100, size[1] / 100))
    axis.imshow(image)
    axis.scatter(where[:, 0], where[:, 1], s=14, c="red", edgecolors="white", linewidths=0.5)
    for (column, row), frame in zip(where, frames):
        axis.annotate(frame, (column, row), xytext=(4, -4), textcoords="offset points", fontsize=6)
    axis.set_title(f"{robot.profile.name}: landmark frames at the start", fontsize=9)
    axis.axis("off")
    figure.tight_layout()
    with atomic_path(path) as temporary:
        figure.savefig(temporary, dpi=100, format="png")
    plt.close(figure)
