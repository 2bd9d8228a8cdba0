"""tric-snapshot: render situations to PNG files (PyBullet's software renderer, no display).

    tric-snapshot SITUATION [SITUATION ...] --out DIR [--situations-file FILE] [--size W H]
                  [--strip FRAMES] [--robot ROBOT]

Each SITUATION is a name from the built-in data sets (sphere_train, sphere_test, cylinder_train,
cylinder_test, obstacle_test, box_train, box_test) or from --situations-file; the robot stands in
its initial configuration. Writes DIR/<name>.png. With --strip FRAMES, the situation's teacher
demonstrates it (directly on the physics, no ROS) and DIR/<name>_strip.png shows FRAMES moments of
the demonstration side by side, with their times. --robot: the robot (a shipped profile's name or a
profile file, docs/robots.md; default tric_arm_hand).
"""

import argparse
import sys

# Only what the arguments need: --help and argument errors answer before pybullet, pinocchio and
# matplotlib are imported (tric_sim.viz.situation_pictures, the rendering, is imported after).
from tric_sim.tools.claims import claim
from tric_sim.tools.interrupts import run_interruptible
from tric_sim.tools.output_files import WriteFailed, check_output_folder
from tric_sim.tools.robot_option import add_robot_option, checked_robot
from tric_sim.world.situations import find_situation


def main(argv=None) -> int:
    return run_interruptible("tric-snapshot", run, argv, "the pictures finished so far kept")


def run(argv) -> int:
    parser = argparse.ArgumentParser(prog="tric-snapshot", description=__doc__.splitlines()[0])
    parser.add_argument("situations", nargs="+", metavar="SITUATION")
    parser.add_argument("--out", default=".", help="output folder (default: .)")
    parser.add_argument("--situations-file", default=None, help="YAML/JSON file to find names in")
    parser.add_argument("--size", nargs=2, type=int, default=(640, 480), metavar=("W", "H"))
    add_robot_option(parser)
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
        profile = checked_robot(args)
        robot = profile.spec
        chosen = [
            find_situation(name, args.situations_file, profile.workspace)
            for name in args.situations
        ]
        out = check_output_folder(args.out, "--out folder")
        held = claim(out, "--out folder", folder=True)
    except ValueError as error:
        print(f"tric-snapshot: {error}", file=sys.stderr)
        return 2
    from tric_sim.viz.situation_pictures import write_pictures

    with held:
        try:
            write_pictures(chosen, out, args.size, args.strip, robot)
        except WriteFailed as error:
            print(f"tric-snapshot: {error}", file=sys.stderr)
            return 2
    return 0


if __name__ == "__main__":
    sys.exit(main())
