"""tric-robot-check: check a robot profile before training on it (docs/robots.md).

    tric-robot-check [ROBOT] [--samples N] [--seed S] [--picture PNG]

ROBOT is a shipped profile's name (default tric_arm_hand) or a profile file (.yaml). Loads the
profile against its URDF (each joint and frame it names must exist), builds the robot in Pinocchio
and PyBullet, and prints for each landmark frame the largest gap between the two over N random
configurations within the joint limits, the largest gap between their masses of the body a joint
moves, then the self-collision pairs' consistency with the SRDF.
With --picture, draws the robot at its start with its landmark frames named. Exit status: 0 all
agree, 1 a check failed, 2 the profile (or an argument) was refused.
"""

import argparse
import sys

# Only what the arguments need: --help and argument errors answer before pybullet and pinocchio
# are imported.
from tric_sim.tools.interrupts import run_interruptible
from tric_sim.tools.output_files import WriteFailed, check_output_file
from tric_sim.world.robot_profile import DEFAULT_ROBOT, load_profile


def main(argv=None) -> int:
    return run_interruptible("tric-robot-check", run, argv)


def run(argv) -> int:
    parser = argparse.ArgumentParser(prog="tric-robot-check", description=__doc__.splitlines()[0])
    parser.add_argument("robot", nargs="?", default=DEFAULT_ROBOT, metavar="ROBOT")
    parser.add_argument("--samples", type=int, default=200, help="configurations (default 200)")
    parser.add_argument("--seed", type=int, default=0, help="of the configurations (default 0)")
    parser.add_argument("--picture", default=None, metavar="PNG", help="draw the landmarks here")
    args = parser.parse_args(argv)
    if args.samples < 1:
        parser.error("--samples takes at least 1")
    try:
        profile = load_profile(args.robot)
        picture = check_output_file(args.picture, (".png",), "--picture") if args.picture else None
    except ValueError as error:
        print(f"tric-robot-check: {error}", file=sys.stderr)
        return 2
    from tric_sim.physics.profile_check import (
        AGREEMENT,
        collision_pair_problems,
        landmark_disagreement,
        mass_disagreement,
    )
    from tric_sim.world.robot_model import RobotModel

    robot = RobotModel(profile)
    print(f"robot profile '{profile.name}' ({profile.path}), digest {profile.digest[:16]}")
    print(
        f"{len(profile.arm_joints)} arm and {len(profile.hand_joints)} hand joints, "
        f"{len(robot.mimic_joints)} mimic; {len(profile.fingers)} fingers; "
        f"{int(robot.hand_geometries.sum())} of {len(robot.hand_geometries)} collision "
        "geometries on the hand"
    )
    worst = landmark_disagreement(robot, args.samples, args.seed)
    print(f"Pinocchio against PyBullet over {args.samples} random configurations (m, rad):")
    width = max(len(frame) for frame in worst)
    for frame, (position, rotation) in worst.items():
        print(f"  {frame:<{width}}  {position:.1e}  {rotation:.1e}")
    disagree = [frame for frame, gaps in worst.items() if max(gaps) >= AGREEMENT]
    masses = mass_disagreement(robot)
    heaviest = max(masses, key=masses.__getitem__)
    print(f"mass of the body a joint moves, worst gap: {masses[heaviest]:.1e} kg ({heaviest})")
    heavier = [joint for joint, gap in masses.items() if gap >= AGREEMENT]
    problems = collision_pair_problems(robot)
    pairs = len(robot.collision_model.collisionPairs)
    print(f"self-collision pairs checked: {pairs}; problems: {len(problems) or 'none'}")
    for problem in problems:
        print(f"  {problem}")
    if picture is not None:
        from tric_sim.viz.landmark_picture import write_landmark_picture

        try:
            write_landmark_picture(robot, picture)
        except WriteFailed as error:
            print(f"tric-robot-check: {error}", file=sys.stderr)
            return 2
        print(f"landmarks drawn in {picture}")
    if disagree:
        print(f"tric-robot-check: Pinocchio and PyBullet place {disagree} apart", file=sys.stderr)
    if heavier:
        print(
            f"tric-robot-check: Pinocchio and PyBullet weigh what {heavier} move differently "
            "(a link without an inertial?)",
            file=sys.stderr,
        )
    return 1 if disagree or heavier or problems else 0


if __name__ == "__main__":
    sys.exit(main())
