"""Pictures of situations (tric-snapshot): the robot in a situation's initial configuration, and a
strip of moments of the teacher's demonstration of it, rendered by PyBullet's software renderer
(no display) and written atomically as PNG files."""

import pathlib

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from tric_sim.physics.simulation import PhysicsWorld  # noqa: E402
from tric_sim.teachers import demonstrate  # noqa: E402
from tric_sim.tools.output_files import atomic_path  # noqa: E402
from tric_sim.world.durations import DEFAULT_DURATION  # noqa: E402
from tric_sim.world.robot_model import RobotModel  # noqa: E402
from tric_sim.world.robot_profile import DEFAULT_ROBOT  # noqa: E402


def demonstration_strip(
    world: PhysicsWorld, robot: RobotModel, situation, frames: int, size
) -> plt.Figure:
    """A figure of `frames` evenly spaced moments of the teacher's demonstration of situation."""
    duration = DEFAULT_DURATION[situation.task]  # the teacher node's
    periods = int(round(duration / world.control_period))
    wanted = {int(round(k * (periods - 1) / (frames - 1))): k for k in range(frames)}
    images: list = [None] * frames  # (seconds, image) of each frame, once captured

    def capture(w, _teacher, period):
        if period in wanted:
            images[wanted[period]] = (period + 1) * w.control_period, w.render(*size)

    demonstrate(world, robot, situation, duration, capture)
    figure, axes = plt.subplots(1, frames, figsize=(2.6 * frames, 2.6 * size[1] / size[0] + 0.4))
    for axis, (seconds, image) in zip(axes, images):
        axis.imshow(image)
        axis.set_title(f"t = {seconds:.1f} s", fontsize=9)
        axis.axis("off")
    figure.suptitle(f"teacher: {situation.name}", fontsize=10)
    figure.tight_layout()
    return figure


def write_png(path, image) -> None:
    """Write an RGB image (height, width, 3) of uint8 to path as a PNG, atomically."""
    with atomic_path(path) as temporary:
        plt.imsave(temporary, image)


def write_pictures(
    situations, out: pathlib.Path, size, strip: int = 0, robot_name: str = DEFAULT_ROBOT
):
    """Write out/<name>.png of each situation's initial state, or with strip (frames) the strip of
    its demonstration as out/<name>_strip.png, printing each path once written; the robot
    robot_name (a profile's name or file)."""
    robot = RobotModel(robot_name)
    world = PhysicsWorld(robot)
    try:
        for situation in situations:
            if strip:
                path = out / f"{situation.name}_strip.png"
                figure = demonstration_strip(world, robot, situation, strip, size)
                with atomic_path(path) as temporary:
                    figure.savefig(temporary, dpi=100)
                plt.close(figure)
                print(path)
                continue
            world.reset(situation)
            world.step()
            path = out / f"{situation.name}.png"
            write_png(path, world.render(*size))
            print(path)
    finally:
        world.close()
