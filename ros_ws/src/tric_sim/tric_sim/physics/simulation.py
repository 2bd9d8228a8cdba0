"""The PyBullet world: the robot (the same URDF as the kinematic model), the table and a situation's
objects, stepped in control periods with position-controlled joints. ROS-free.

Grasp targets float where the situation puts them, held by a fixture (a fixed constraint) until
release_object() lets gravity act on them (the lift test). The situation's perturbations
(tric_sim.world.perturbations), and those schedule() adds, act as the periods they fall in are
stepped: a push moves the joints' setpoints (and targets) within the joint limits, a target move
moves the fixture. The box body is static; its lid is a link on a hinge with friction
(tric_sim.physics.bullet_scene builds them). The joints' hard stops are held after every physics
step (tric_sim.physics.joint_stops). Units: m, rad, s, kg, N m.
"""

import dataclasses
from typing import cast

import numpy as np

from tric_sim.physics.bullet import pb, quiet_stdout
from tric_sim.physics.bullet_scene import create_body, robot_contact_rules
from tric_sim.physics.joint_stops import JointStops
from tric_sim.world import scene
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.scene_check import check_scene
from tric_sim.world.situation import Situation

#: Distance beyond which robot-to-scene distances are not resolved (reported as this value), m: the
#: contact-breaking threshold, within which PyBullet reports contact points with their distance.
DISTANCE_CUTOFF = 0.02
#: Gains of the joint servos (PyBullet's POSITION_CONTROL: position and velocity error weights).
POSITION_GAIN = 0.1
VELOCITY_GAIN = 1.0
#: The most force the fixture holding a grasp target in place may exert, N.
FIXTURE_FORCE = 1e4


class PhysicsWorld:
    """A PyBullet DIRECT (or GUI) client holding the robot and one situation's scene.

    Args:
        robot: the shared kinematic model (its URDF is loaded).
        physics_rate_hz: physics steps per second (>= 240, a multiple of control_rate_hz).
        control_rate_hz: control periods per second; step() advances one period.
        solver_iterations: constraint-solver iterations per physics step.
        gui: open PyBullet's GUI instead of the headless DIRECT mode.
    """

    def __init__(
        self,
        robot: RobotModel,
        physics_rate_hz: float = 300.0,
        control_rate_hz: float = 100.0,
        solver_iterations: int = 10,
        gui: bool = False,
    ):
        substeps = physics_rate_hz / control_rate_hz
        if physics_rate_hz < 240 or abs(substeps - round(substeps)) > 1e-9 or substeps < 1:
            raise ValueError(
                f"physics_rate_hz ({physics_rate_hz}) must be >= 240 and an integer "
                f"multiple of control_rate_hz ({control_rate_hz})"
            )
        self.robot = robot
        self.control_period = 1.0 / control_rate_hz
        self.control_period_ns = int(round(1e9 / control_rate_hz))
        self.substeps = int(round(substeps))
        self.client = pb.connect(pb.GUI if gui else pb.DIRECT)
        pb.setGravity(0, 0, -9.81, physicsClientId=self.client)
        # One stepSimulation call per physics step: the joints' stops are enforced after each.
        pb.setPhysicsEngineParameter(
            fixedTimeStep=self.control_period / self.substeps,
            numSubSteps=1,
            numSolverIterations=solver_iterations,
            contactBreakingThreshold=DISTANCE_CUTOFF,
            deterministicOverlappingPairs=1,
            physicsClientId=self.client,
        )
        flags = (
            pb.URDF_MERGE_FIXED_LINKS
            | pb.URDF_USE_SELF_COLLISION
            | pb.URDF_USE_SELF_COLLISION_EXCLUDE_ALL_PARENTS
            | pb.URDF_USE_MATERIAL_COLORS_FROM_MTL
        )
        with quiet_stdout():
            self.robot_id = pb.loadURDF(
                str(robot.urdf_path), useFixedBase=True, flags=flags, physicsClientId=self.client
            )
        self.link_index = {}
        joint_index = {}
        for i in range(pb.getNumJoints(self.robot_id, physicsClientId=self.client)):
            info = pb.getJointInfo(self.robot_id, i, physicsClientId=self.client)
            self.link_index[info[12].decode()] = i
            if info[2] in (pb.JOINT_REVOLUTE, pb.JOINT_PRISMATIC):
                joint_index[info[1].decode()] = i
        self.actuated = [joint_index[name] for name in robot.joint_names]
        self.mounted_links = robot_contact_rules(self.client, self.robot_id, robot, self.link_index)
        self.mimics = [
            (joint_index[m.name], robot.joint_names.index(m.source), m.multiplier, m.offset)
            for m in robot.mimic_joints
        ]
        self.all_joints = self.actuated + [m[0] for m in self.mimics]
        # mimic joint positions = _mimic_matrix @ q + _mimic_offset
        self._mimic_matrix = np.zeros((len(self.mimics), robot.n_joints))
        for row, (_, source, multiplier, _) in enumerate(self.mimics):
            self._mimic_matrix[row, source] = multiplier
        self._mimic_offset = np.array([m[3] for m in self.mimics])
        sources = [m[1] for m in self.mimics]
        self._forces = list(robot.effort_limits) + [robot.effort_limits[k] for k in sources]
        self._position_gains = [POSITION_GAIN] * len(self.all_joints)
        self._velocity_gains = [VELOCITY_GAIN] * len(self.all_joints)
        self.stops = JointStops(self.client, self.robot_id, self.all_joints)
        self.periods = 0
        self.situation: Situation | None = None
        self.bodies: dict[str, int] = {}
        self.body_roles: dict[str, str] = {}
        self.fixture = None
        self.fixture_position = np.zeros(3)
        self.reset_period = 0
        self.targets = robot.home.copy()
        self.setpoint = robot.home.copy()
        self.min_distance = DISTANCE_CUTOFF

    def close(self) -> None:
        if pb.isConnected(self.client):
            pb.disconnect(self.client)

    # --- scene ---------------------------------------------------------------------------------

    def reset(self, situation: Situation) -> None:
        """Replace the scene by the situation's and put the robot at its initial configuration.
        The clock advances by one control period, so that the new scene's first state is stamped
        after every state of the previous one (subscribers tell the scenes apart by stamp).
        ValueError for an invalid or physically impossible situation (scene_check.check_scene)."""
        check_scene(situation.validate(self.robot.n_joints), self.robot)
        q0 = (
            self.robot.check_configuration(
                situation.initial_joint_positions, "initial_joint_positions"
            )
            if situation.initial_joint_positions
            else self.robot.home.copy()
        )
        self.release_object()
        for body in self.bodies.values():
            pb.removeBody(body, physicsClientId=self.client)
        self.bodies, self.body_roles = {}, {}
        client = self.client
        for body in scene.scene_bodies(situation):
            if body.role == "lid":
                continue  # built as a link of the box body
            self.body_roles[body.name] = body.role
            uid = self.bodies[body.name] = create_body(self.client, body, situation)
            for link in self.mounted_links - {-1} if body.role == "table" else ():
                # a link mounted with the base rests on the table: never a collision there
                pb.setCollisionFilterPair(self.robot_id, uid, link, -1, 0, physicsClientId=client)
        if situation.object_kind in scene.OBJECT_MASS:
            position, orientation = situation.object_position, situation.object_orientation
            self.fixture = pb.createConstraint(
                self.bodies["object"],
                -1,
                -1,
                -1,
                pb.JOINT_FIXED,
                [0, 0, 0],
                [0, 0, 0],
                position,
                childFrameOrientation=orientation,
                physicsClientId=self.client,
            )
            pb.changeConstraint(self.fixture, maxForce=FIXTURE_FORCE, physicsClientId=self.client)
            self.fixture_position = np.array(position, dtype=float)
        angles = self.robot.urdf_joint_positions(q0)
        for name, index in zip(self.robot.joint_names, self.actuated):
            pb.resetJointState(self.robot_id, index, angles[name], 0.0, physicsClientId=self.client)
        for index, source, multiplier, offset in self.mimics:
            pb.resetJointState(
                self.robot_id,
                index,
                multiplier * q0[source] + offset,
                0.0,
                physicsClientId=self.client,
            )
        self.situation = situation
        self.setpoint = q0.copy()
        self.command(q0)
        self.min_distance = self.closest_distance()
        self.stops.clear()
        self.periods += 1
        self.reset_period = self.periods

    def schedule(self, perturbations) -> None:
        """Add perturbations (tric_sim.world.perturbations.Perturbation) to the current episode, at
        their start_s after the last reset. ValueError, and nothing scheduled, for one that the
        situation refuses (Situation.validate) or that starts before the current period."""
        if self.situation is None:
            raise ValueError("no scene: reset the simulator to a situation first")
        perturbations = tuple(perturbations)
        extended = dataclasses.replace(
            self.situation, perturbations=self.situation.perturbations + perturbations
        )
        checked = check_scene(extended.validate(self.robot.n_joints), self.robot)
        for k, perturbation in enumerate(perturbations):
            if perturbation.start_s < self.elapsed_s:
                raise ValueError(
                    f"perturbation {k} starts at {perturbation.start_s:g} s, but the episode is "
                    f"at {self.elapsed_s:g} s already"
                )
        self.situation = checked

    @property
    def elapsed_s(self) -> float:
        """Simulated time since the last reset, s."""
        return (self.periods - self.reset_period) * self.control_period

    def release_object(self) -> None:
        """Remove the grasp target's fixture, so that gravity and the hand alone hold it."""
        if self.fixture is not None:
            pb.removeConstraint(self.fixture, physicsClientId=self.client)
            self.fixture = None

    # --- control -------------------------------------------------------------------------------

    def command(self, q_target) -> None:
        """Set the joints' position targets (n,), rad. The joint servos move their setpoints towards
        the targets no faster than the joints' velocity limits; mimic joints follow their source."""
        self.targets = np.array(q_target, dtype=float)

    def step(self) -> None:
        """Advance one control period (self.substeps physics steps), with the perturbations that
        fall in it."""
        push = self._perturb()
        max_step = self.robot.velocity_limits * self.control_period
        delta = np.clip(self.targets - self.setpoint, -max_step, max_step)
        self.setpoint = self.setpoint + delta
        positions = np.concatenate(
            [self.setpoint, self._mimic_matrix @ self.setpoint + self._mimic_offset]
        )
        motion = delta + push
        velocities = np.concatenate([motion, self._mimic_matrix @ motion]) / self.control_period
        pb.setJointMotorControlArray(
            self.robot_id,
            self.all_joints,
            pb.POSITION_CONTROL,
            targetPositions=positions.tolist(),
            targetVelocities=velocities.tolist(),
            forces=self._forces,
            positionGains=self._position_gains,
            velocityGains=self._velocity_gains,
            physicsClientId=self.client,
        )
        box = self._box()
        for _ in range(self.substeps):
            pb.stepSimulation(physicsClientId=self.client)
            self.stops.enforce(box)
        self.periods += 1
        self.min_distance = min(self.min_distance, self.closest_distance())
        self.stops.measure(box)

    def _perturb(self) -> np.ndarray:
        """Act the perturbations falling in the coming period: move the fixture by the target
        moves, and the setpoint and targets by the pushes (within the joint limits); returns the
        push made (n,) rad, which the servos then follow."""
        t0 = self.elapsed_s
        t1 = t0 + self.control_period
        push, move = np.zeros(self.robot.n_joints), np.zeros(3)
        for perturbation in self.situation.perturbations if self.situation else ():
            share = perturbation.share(t0, t1)
            if share and perturbation.kind == "push":
                push += share * np.asarray(perturbation.offset)
            elif share:
                move += share * np.asarray(perturbation.offset)
        if np.any(move) and self.fixture is not None:
            self.fixture_position = self.fixture_position + move
            pb.changeConstraint(
                self.fixture,
                jointChildPivot=self.fixture_position.tolist(),
                maxForce=FIXTURE_FORCE,
                physicsClientId=self.client,
            )
        if not np.any(push):
            return push
        pushed = np.clip(self.setpoint + push, self.robot.lower, self.robot.upper)
        push, self.setpoint = pushed - self.setpoint, pushed
        self.targets = np.clip(self.targets + push, self.robot.lower, self.robot.upper)
        return push

    def _box(self):
        """The box's body id (its link 0 is the lid), or None in a scene without a box."""
        uid = self.bodies.get("object")
        return uid if uid is not None and self.body_roles["object"] == "box_body" else None

    # --- state ---------------------------------------------------------------------------------

    @property
    def time_ns(self) -> int:
        """Simulated time since the world was created, ns (strictly increasing across resets)."""
        return self.periods * self.control_period_ns

    def joint_state(self):
        """(positions, velocities) of the actuated joints, (n,) each, rad and rad/s."""
        states = pb.getJointStates(self.robot_id, self.actuated, physicsClientId=self.client)
        return np.array([s[0] for s in states]), np.array([s[1] for s in states])

    def object_poses(self) -> dict:
        """World pose of every object: name -> (position (3,), xyzw quaternion). The lid's pose is
        its hinge frame ("lid", see scene), and "lid_edge" is its lip (scene.lid_edge_offset)."""
        poses = {}
        for name, uid in self.bodies.items():
            if self.body_roles[name] == "table":
                continue
            position, orientation = pb.getBasePositionAndOrientation(
                uid, physicsClientId=self.client
            )
            poses[name] = (tuple(position), tuple(orientation))
            if self.body_roles[name] == "box_body":
                link = pb.getLinkState(
                    uid, 0, computeForwardKinematics=True, physicsClientId=self.client
                )
                poses["lid"] = (tuple(link[4]), tuple(link[5]))
                # a box body exists only once reset has set the situation
                situation = cast(Situation, self.situation)
                edge = scene.se3(link[4], link[5]) * scene.lid_edge_offset(
                    situation.object_dimensions[0]
                )
                poses["lid_edge"] = scene.pose_tuple(edge)
        return poses

    def lid_angle(self) -> float:
        """Opening angle of the box's lid, rad (NaN when the scene has no box)."""
        box = self._box()
        if box is None:
            return float("nan")
        return float(pb.getJointState(box, 0, physicsClientId=self.client)[0])

    def link_placements(self) -> dict:
        """World placement (position, xyzw) of each robot link PyBullet simulates, by link name."""
        out = {}
        for name, index in self.link_index.items():
            state = pb.getLinkState(
                self.robot_id, index, computeForwardKinematics=True, physicsClientId=self.client
            )
            out[name] = (np.array(state[4]), np.array(state[5]))
        return out

    def closest_distance(self) -> float:
        """Smallest signed distance between the robot and the avoided bodies (table, obstacles, box
        body) at the last physics step, m, capped at DISTANCE_CUTOFF. The robot's base, mounted on
        the table, is left out (and its profile's mounted links)."""
        best = DISTANCE_CUTOFF
        for name, uid in self.bodies.items():
            if self.body_roles[name] not in scene.AVOIDED_ROLES:
                continue
            for point in pb.getContactPoints(
                self.robot_id, uid, linkIndexB=-1, physicsClientId=self.client
            ):
                if point[3] not in self.mounted_links:
                    best = min(best, point[8])
        return best

    def contacts_with(self, name: str) -> list:
        """Robot link names in contact with the named object (for the lid: its link)."""
        uid = self.bodies.get(name)
        if uid is None and name == "lid":
            uid = self.bodies.get("object")
        if uid is None:
            return []
        names = {index: link for link, index in self.link_index.items()}
        points = pb.getContactPoints(self.robot_id, uid, physicsClientId=self.client)
        return sorted({names.get(p[3], self.robot.profile.base) for p in points})

    # --- pictures ------------------------------------------------------------------------------

    def render(
        self, width: int = 640, height: int = 480, eye=None, target=None, fov_deg: float = 50.0
    ) -> np.ndarray:
        """An RGB image (height, width, 3) of the scene from eye looking at target (world, m),
        made by PyBullet's software renderer (no display needed)."""
        if eye is None or target is None or np.allclose(eye, target):
            target = np.asarray(self.situation.object_position if self.situation else (0.5, 0, 0.3))
            target = (0.5 * target + 0.5 * np.array([0.35, 0.0, 0.35])).tolist()
            eye = [target[0] + 0.55, target[1] - 1.25, target[2] + 0.65]
        view = pb.computeViewMatrix(list(eye), list(target), [0, 0, 1], physicsClientId=self.client)
        projection = pb.computeProjectionMatrixFOV(
            fov_deg, width / height, 0.05, 5.0, physicsClientId=self.client
        )
        image = pb.getCameraImage(
            width,
            height,
            view,
            projection,
            renderer=pb.ER_TINY_RENDERER,
            lightDirection=[0.6, -0.4, 1.0],
            shadow=1,
            physicsClientId=self.client,
        )
        rgba = np.reshape(np.asarray(image[2], dtype=np.uint8), (height, width, 4))
        return rgba[:, :, :3].copy()
