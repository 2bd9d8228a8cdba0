"""tric-snapshot: render situations to PNG files (PyBullet's software renderer, no display).

    tric-snapshot SITUATION [SITUATION ...] --out DIR [--situations-file FILE] [--size W H]
                  [--strip FRAMES]

Each SITUATION is a name from the built-in data sets (sphere_train, sphere_test, cylinder_train,
cylinder_test, obstacle_test, box_train, box_test) or from --situations-file; the robot stands in
its initial configuration. Writes DIR/<name>.png. With --strip FRAMES, the situation's teacher
demonstrates it (directly on the physics, no ROS) and DIR/<name>_strip.png shows FRAMES moments of
the demonstration side by side, with their times.
"""

import argparse
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from tric_sim.interrupts import run_interruptible  # noqa: E402
from tric_sim.output_files import atomic_path, check_output_folder  # noqa: E402
from tric_sim.physics import PhysicsWorld  # noqa: E402
from tric_sim.robot_model import RobotModel  # noqa: E402
from tric_sim.situations import find_situation  # noqa: E402
from tric_sim.teachers import demonstrate  # noqa: E402

#: Demonstration lengths of the strips by task, simulated s (as the teacher node's defaults).
STRIP_DURATION = {"grasp": 5.0, "open_box": 8.0}


def demonstration_strip(
    world: PhysicsWorld, robot: RobotModel, situation, frames: int, size
) -> plt.Figure:
    """A figure of `frames` evenly spaced moments of the teacher's demonstration of situation."""
    duration = STRIP_DURATION[situation.task]
    periods = int(round(duration / world.control_period))
    wanted = {int(round(k * (periods - 1) / (frames - 1))): k for k in range(frames)}
    images = [None] * frames

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


def main(argv=None) -> int:
    return run_interruptible("tric-snapshot", run, argv, "the pictures finished so far kept")


def run(argv) -> int:
    parser = argparse.ArgumentParser(prog="tric-snapshot", description=__doc__.splitlines()[0])
    parser.add_argument("situations", nargs="+", metavar="SITUATION")
    parser.add_argument("--out", default=".", help="output folder (default: .)")
    parser.add_argument("--situations-file", default=None, help="YAML/JSON file to find names in")
    parser.add_argument("--size", nargs=2, type=int, default=(640, 480), metavar=("W", "H"))
    parser.add_argument(
        "--strip",
        type=int,
        default=0,
        metavar="FRAMES",
        help="render FRAMES moments of the teacher's demonstration instead (2 to 12)",
    )
    args = parser.parse_args(argv)
    if args.strip and not 2 <= args.strip <= 12:
        parser.error("--strip takes 2 to 12 frames")
    try:
        chosen = [find_situation(name, args.situations_file) for name in args.situations]
        out = check_output_folder(args.out, "--out folder")
    except ValueError as error:
        print(f"tric-snapshot: {error}", file=sys.stderr)
        return 2
    robot = RobotModel()
    world = PhysicsWorld(robot)
    try:
        for situation in chosen:
            if args.strip:
                path = out / f"{situation.name}_strip.png"
                figure = demonstration_strip(world, robot, situation, args.strip, args.size)
                with atomic_path(path) as temporary:
                    figure.savefig(temporary, dpi=100)
                plt.close(figure)
                print(path)
                continue
            world.reset(situation)
            world.step()
            path = out / f"{situation.name}.png"
            with atomic_path(path) as temporary:
                plt.imsave(temporary, world.render(*args.size))
            print(path)
    finally:
        world.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
