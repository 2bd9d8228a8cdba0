"""The `--robot` option of the command-line tools: the robot a tool works with, a profile shipped
with tric_sim (its name) or a profile file (docs/robots.md), checked against its URDF before any
work (a refused profile is a ValueError naming the file and the entry)."""

from tric_sim.world.robot_profile import DEFAULT_ROBOT, load_profile


def add_robot_option(parser) -> None:
    """Add --robot to an argparse parser."""
    parser.add_argument(
        "--robot",
        default=DEFAULT_ROBOT,
        help=f"the robot: a shipped profile's name or a profile file (default: {DEFAULT_ROBOT})",
    )


def checked_robot(args) -> str:
    """args.robot as the tools pass it on (tric_sim.world.robot_profile.RobotProfile.spec), once
    its profile loads; ValueError naming the problem otherwise."""
    return load_profile(args.robot).spec
