"""Checks of a robot profile against the simulator (tric-robot-check, and the tests of every
shipped profile): Pinocchio and PyBullet place each landmark frame alike over random
configurations and weigh alike the body each joint moves (PyBullet gives a link without an
inertial 1 kg, Pinocchio nothing), and the self-collision pairs are consistent with the URDF and
the SRDF. Units: m, rad, kg."""

import xml.etree.ElementTree as ET

import numpy as np
import pinocchio as pin
import pybullet as pb

from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.world import scene, situations
from tric_sim.world.robot_model import RobotModel

#: Pinocchio and PyBullet agree on a frame when they place it this close, m and rad; on a body's
#: mass when they weigh it this close, kg.
AGREEMENT = 1e-6


def landmark_frames(robot: RobotModel) -> tuple:
    """The frames the method reads on the robot: its base, palm, grasp centre (if named), and each
    finger's tip, middle, base and links (the lid fingertips are fingertips), sorted."""
    profile = robot.profile
    frames = {profile.base, profile.palm, *profile.grasp_centres, *profile.lid_fingertips}
    for finger in profile.fingers:
        frames |= {finger.tip, finger.middle, finger.base, *finger.links}
    return tuple(sorted(frames))


def _fixed_joints(robot: RobotModel) -> dict:
    """URDF child link -> (parent link, placement) of each fixed joint."""
    chains = {}
    for joint in ET.parse(robot.urdf_path).getroot().iter("joint"):
        if joint.get("type") != "fixed":
            continue
        origin = joint.find("origin")
        xyz = origin.get("xyz", "0 0 0") if origin is not None else "0 0 0"
        rpy = origin.get("rpy", "0 0 0") if origin is not None else "0 0 0"
        placement = pin.SE3(
            pin.rpy.rpyToMatrix(*[float(v) for v in rpy.split()]),
            np.array([float(v) for v in xyz.split()]),
        )
        child, parent = joint.find("child"), joint.find("parent")
        if child is not None and parent is not None:  # a URDF joint names both
            chains[child.get("link")] = (parent.get("link"), placement)
    return chains


def _pybullet_placement(world: PhysicsWorld, chains: dict, frame: str) -> pin.SE3:
    """A frame's world placement as PyBullet has it: its link's, or that of the simulated link
    that carries it (PyBullet merges fixed links into their parent) composed with the fixed joints
    in between; the base's from its centre of mass, where PyBullet places it."""
    offset = pin.SE3.Identity()
    while frame not in world.link_index and frame in chains:
        frame, placement = chains[frame]
        offset = placement * offset
    if frame in world.link_index:
        state = pb.getLinkState(
            world.robot_id,
            world.link_index[frame],
            computeForwardKinematics=True,
            physicsClientId=world.client,
        )
        return scene.se3(np.array(state[4]), np.array(state[5])) * offset
    position, orientation = pb.getBasePositionAndOrientation(
        world.robot_id, physicsClientId=world.client
    )
    inertial = pb.getDynamicsInfo(world.robot_id, -1, physicsClientId=world.client)
    centre = scene.se3(np.array(inertial[3]), np.array(inertial[4]))
    return scene.se3(np.array(position), np.array(orientation)) * centre.inverse() * offset


def _random_configurations(world: PhysicsWorld, robot: RobotModel, samples: int, seed: int):
    """Yield `samples` configurations drawn uniformly within the joint limits, each set in PyBullet
    (every joint, the mimic ones included) and in the robot's Pinocchio data."""
    world.reset(situations.sphere("profile_check", (0.6, 0.0, 0.35)))
    rng = np.random.default_rng(seed)
    index = dict(zip(robot.joint_names, world.actuated))
    index.update((m.name, w[0]) for m, w in zip(robot.mimic_joints, world.mimics))
    for _ in range(samples):
        q = rng.uniform(robot.lower, robot.upper)
        for joint, angle in robot.urdf_joint_positions(q).items():
            pb.resetJointState(world.robot_id, index[joint], angle, physicsClientId=world.client)
        robot.forward(q)
        yield q


def mass_disagreement(robot: RobotModel) -> dict:
    """joint -> |Pinocchio's - PyBullet's| mass of the body the joint moves (its link and the links
    fixed below it), kg. PyBullet gives a link without an inertial 1 kg, Pinocchio nothing."""
    model = robot.model
    pinocchio = {model.names[i]: model.inertias[i].mass for i in range(1, model.njoints)}
    gaps = {}
    world = PhysicsWorld(robot)
    try:
        for link in range(pb.getNumJoints(world.robot_id, physicsClientId=world.client)):
            info = pb.getJointInfo(world.robot_id, link, physicsClientId=world.client)
            joint = info[1].decode()
            if joint in pinocchio:
                mass = pb.getDynamicsInfo(world.robot_id, link, physicsClientId=world.client)[0]
                gaps[joint] = abs(pinocchio[joint] - mass)
    finally:
        world.close()
    return gaps


def landmark_disagreement(robot: RobotModel, samples: int = 25, seed: int = 0) -> dict:
    """frame -> (worst position gap m, worst rotation gap rad) between Pinocchio's and PyBullet's
    placement of each landmark frame over `samples` configurations drawn uniformly within the
    joint limits."""
    chains = _fixed_joints(robot)
    frames = landmark_frames(robot)
    worst = {frame: (0.0, 0.0) for frame in frames}
    world = PhysicsWorld(robot)
    try:
        for _ in _random_configurations(world, robot, samples, seed):
            for frame in frames:
                expected = robot.frame_placement(frame)
                got = _pybullet_placement(world, chains, frame)
                position = float(np.abs(expected.translation - got.translation).max())
                rotation = float(np.linalg.norm(pin.log3(expected.rotation.T @ got.rotation)))
                worst[frame] = (max(worst[frame][0], position), max(worst[frame][1], rotation))
    finally:
        world.close()
    return worst


def collision_pair_problems(robot: RobotModel) -> list:
    """What is wrong with the robot's self-collision pairs (empty: nothing): the SRDF naming a link
    the URDF lacks, a checked pair within one link or between neighbours, a checked pair the SRDF
    disables."""
    links = {str(link.get("name")) for link in ET.parse(robot.urdf_path).getroot().iter("link")}
    disabled = {
        frozenset((str(tag.get("link1")), str(tag.get("link2"))))
        for tag in ET.parse(robot.profile.srdf_path).getroot().iter("disable_collisions")
    }
    problems = [
        f"the SRDF names links the URDF lacks: {sorted(pair - links)}"
        for pair in disabled
        if not pair <= links
    ]
    geometries, model = robot.collision_model.geometryObjects, robot.model
    for pair in robot.collision_model.collisionPairs:
        a, b = geometries[pair.first], geometries[pair.second]
        names = frozenset((model.frames[a.parentFrame].name, model.frames[b.parentFrame].name))
        joints = (a.parentJoint, b.parentJoint)
        if (
            a.parentJoint == b.parentJoint
            or model.parents[joints[0]] == joints[1]
            or (model.parents[joints[1]] == joints[0])
        ):
            problems.append(f"{a.name}/{b.name} is checked, on one link or on neighbours")
        if names in disabled:
            problems.append(f"{a.name}/{b.name} is checked though the SRDF disables it")
    return problems
