"""The `--robot` option of the command-line tools: the robot a tool works with, a profile shipped
with tric_sim (its name) or a profile file (docs/robots.md), checked against its URDF before any
work (a refused profile is a ValueError naming the file and the entry); and where a robot's
reference bags are."""

import pathlib

from tric_sim.world.robot_profile import DEFAULT_ROBOT, RobotProfile, load_profile

#: The reference bags (bags/README.md): the paper's robot's in bags/<set>, another robot's in
#: bags/<its name>/<set>, relative to the repository's root.
REFERENCE_BAGS = pathlib.Path("bags")


def add_robot_option(parser) -> None:
    """Add --robot to an argparse parser."""
    parser.add_argument(
        "--robot",
        default=DEFAULT_ROBOT,
        help=f"the robot: a shipped profile's name or a profile file (default: {DEFAULT_ROBOT})",
    )


def checked_robot(args) -> RobotProfile:
    """The profile of args.robot, once it loads (its `spec` is what the tools pass on, its
    workspace where the built-in data sets put their objects); ValueError naming the problem
    otherwise."""
    return load_profile(args.robot)


def reference_bags(profile: RobotProfile, folder: str) -> pathlib.Path:
    """The folder of a robot's reference bags of one set (e.g. "sphere")."""
    if profile.name == DEFAULT_ROBOT:
        return REFERENCE_BAGS / folder
    return REFERENCE_BAGS / profile.name / folder
