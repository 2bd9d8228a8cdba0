"""tric-snapshot: render situations to PNG files (PyBullet's software renderer, no display).

    tric-snapshot SITUATION [SITUATION ...] --out DIR [--situations-file FILE] [--size W H]

Each SITUATION is a name from the built-in data sets (sphere_train, sphere_test, cylinder_train,
cylinder_test, obstacle_test, box_train, box_test) or from --situations-file; the robot stands in its
initial configuration. Writes DIR/<name>.png.
"""

import argparse
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

from tric_sim.physics import PhysicsWorld  # noqa: E402
from tric_sim.robot_model import RobotModel  # noqa: E402
from tric_sim.situations import find_situation  # noqa: E402


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="tric-snapshot", description=__doc__.splitlines()[0])
    parser.add_argument("situations", nargs="+", metavar="SITUATION")
    parser.add_argument("--out", default=".", help="output folder (default: .)")
    parser.add_argument("--situations-file", default=None, help="YAML/JSON file to find names in")
    parser.add_argument("--size", nargs=2, type=int, default=(640, 480), metavar=("W", "H"))
    args = parser.parse_args(argv)
    try:
        chosen = [find_situation(name, args.situations_file) for name in args.situations]
    except ValueError as error:
        print(f"tric-snapshot: {error}", file=sys.stderr)
        return 2
    out = pathlib.Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    world = PhysicsWorld(RobotModel())
    try:
        for situation in chosen:
            world.reset(situation)
            world.step()
            path = out / f"{situation.name}.png"
            plt.imsave(path, world.render(*args.size))
            print(path)
    finally:
        world.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
