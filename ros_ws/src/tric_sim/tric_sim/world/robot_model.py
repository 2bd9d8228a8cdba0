"""The robot's kinematic and collision model, built once from its profile's URDF
(tric_sim.world.robot_profile) and shared by everyone.

The simulator (PyBullet) loads the very same URDF file. Pinocchio parses it with mimic joints, so
q has one entry per actuated joint (the paper's robot: 7 arm + 7 hand, the knuckle of finger 3
following finger 2's). Units: m, rad, s.
"""

import copy
import pathlib
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import cast

import numpy as np
import pinocchio as pin

from tric_sim.world.robot_profile import DEFAULT_ROBOT, RobotProfile, load_profile

#: The rows of the spatial Jacobian (linear 0-2, angular 3-5) and their signs that give, for each
#: axis a, [Jv_a, (e_x x Jw)_a, (e_y x Jw)_a, (e_z x Jw)_a] (RobotModel.point_jacobians).
_CROSS_ROWS = np.array([[0, 0, 5, 4], [1, 5, 0, 3], [2, 4, 3, 0]])
_CROSS_SIGNS = np.array([[1.0, 0.0, 1.0, -1.0], [1.0, -1.0, 0.0, 1.0], [1.0, 1.0, -1.0, 0.0]])[
    :, None, :
]


@dataclass(frozen=True)
class MimicJoint:
    """A URDF joint whose angle is multiplier * angle(source) + offset (rad)."""

    name: str
    source: str
    multiplier: float
    offset: float


def _parse_axes(urdf_path: pathlib.Path) -> dict:
    """Joint name -> (unit axis (3,), whether it is prismatic) of every revolute (a rotation about
    the axis) and prismatic (a translation along it) joint in the URDF."""
    axes = {}
    for joint in ET.parse(urdf_path).getroot().iter("joint"):
        if joint.get("type") in ("revolute", "prismatic"):
            tag = joint.find("axis")
            axis = (
                np.array([float(v) for v in cast(str, tag.get("xyz")).split()])
                if tag is not None
                else np.array([1.0, 0, 0])
            )
            sliding = joint.get("type") == "prismatic"
            axes[joint.get("name")] = (axis / np.linalg.norm(axis), sliding)
    return axes


def _parse_mimics(urdf_path: pathlib.Path) -> tuple:
    root = ET.parse(urdf_path).getroot()
    mimics = []
    for joint in root.iter("joint"):
        tag = joint.find("mimic")
        if tag is not None:
            # a URDF joint has a name, and its mimic tag names the joint it follows
            mimics.append(
                MimicJoint(
                    cast(str, joint.get("name")),
                    cast(str, tag.get("joint")),
                    float(tag.get("multiplier", 1.0)),
                    float(tag.get("offset", 0.0)),
                )
            )
    return tuple(mimics)


class RobotModel:
    """Pinocchio model, data and collision model of the arm + hand of a robot profile (a name, a
    profile file, or a loaded RobotProfile).

    Self-collision pairs: every pair of geometries on non-adjacent links, less those the profile's
    SRDF disables (use_srdf=False keeps them all).

    Attributes:
        profile: the robot's RobotProfile.
        joint_names: the n actuated joints, in the order of q.
        home: the profile's start configuration (n,), rad.
        lower, upper: joint limits (n,), rad (m for a prismatic joint).
        prismatic: (n,) bool, which joints slide (their q in m) rather than turn (rad).
        velocity_limits: (n,) rad/s; effort_limits: (n,) N m.
        mimic_joints: URDF joints driven by another joint (not part of q).
        hand_geometries: (G,) bool, which collision geometries are on the hand (its profile's
            hand_links); mounted_geometries: (G,) bool, which are fixed to the world or on its
            profile's mounted_links (never checked against the scene).
        closing_signs: (n,) +1.0 where a finger closes as the joint rises, -1.0 where as it falls
            (its profile's; +1.0 for the joints of no finger).
    """

    def __init__(
        self, profile: RobotProfile | str | pathlib.Path = DEFAULT_ROBOT, use_srdf: bool = True
    ):
        self.profile = profile if isinstance(profile, RobotProfile) else load_profile(profile)
        self.urdf_path = self.profile.urdf_path
        self.model = pin.buildModelFromUrdf(str(self.urdf_path), mimic=True)
        self.data = self.model.createData()
        self.collision_model = pin.buildGeomFromUrdf(
            self.model, str(self.urdf_path), pin.GeometryType.COLLISION
        )
        self._add_self_collision_pairs()
        if use_srdf:
            pin.removeCollisionPairs(self.model, self.collision_model, str(self.profile.srdf_path))
        self.collision_data = pin.GeometryData(self.collision_model)
        geometry_links = [
            self.model.frames[g.parentFrame].name for g in self.collision_model.geometryObjects
        ]
        hand = self.profile.hand_links
        self.hand_geometries = np.array([link in hand for link in geometry_links])
        self.mounted_geometries = np.array(
            [
                g.parentJoint == 0 or link in self.profile.mounted_links
                for g, link in zip(self.collision_model.geometryObjects, geometry_links)
            ]
        )
        self.joint_names = tuple(
            name
            for name, joint in zip(self.model.names[1:], self.model.joints[1:])
            if joint.nq == 1
        )
        assert len(self.joint_names) == self.model.nq, "one q entry per actuated joint"
        self.lower = self.model.lowerPositionLimit.copy()
        self.upper = self.model.upperPositionLimit.copy()
        self.velocity_limits = self.model.velocityLimit.copy()
        self.effort_limits = self.model.effortLimit.copy()
        self.mimic_joints = _parse_mimics(self.urdf_path)
        self.home = np.array([self.profile.home[j] for j in self.joint_names])
        self.arm_indices = np.array([self.joint_names.index(j) for j in self.profile.arm_joints])
        self.hand_indices = np.array([self.joint_names.index(j) for j in self.profile.hand_joints])
        signs = self.profile.closing_signs
        self.closing_signs = np.array([signs.get(j, 1.0) for j in self.joint_names])
        self._chain = self._kinematic_chain()
        self.prismatic = np.zeros(len(self.joint_names), dtype=bool)
        for *_, sliding, source, _multiplier, _offset in self._chain:
            self.prismatic[source] |= sliding
        self.joint_supports, self.extended_to_q = self._jacobian_columns()
        columns = self.model.nvExtended
        # (3, E, 4)
        self._cross_index = _CROSS_ROWS[:, None, :] * columns + np.arange(columns)[:, None]

    def copy(self) -> "RobotModel":
        """The same model with its own Pinocchio data (for use from another thread)."""
        clone = copy.copy(self)
        clone.data = self.model.createData()
        clone.collision_data = pin.GeometryData(self.collision_model)
        return clone

    @property
    def n_joints(self) -> int:
        return self.model.nq

    def _add_self_collision_pairs(self):
        """All pairs of robot geometries except those on the same or on adjacent (parent/child)
        joints."""
        geoms = self.collision_model.geometryObjects
        parents = self.model.parents
        mount = self.model.frames[self.frame_id(self.profile.hand_root)].parentJoint
        for a in range(len(geoms)):
            for b in range(a + 1, len(geoms)):
                ja, jb = geoms[a].parentJoint, geoms[b].parentJoint
                if ja == jb or parents[ja] == jb or parents[jb] == ja:
                    continue
                # Siblings on the palm (finger chains' first links, the palm itself) touch by
                # design.
                if parents[ja] == parents[jb] == mount:
                    continue
                self.collision_model.addCollisionPair(pin.CollisionPair(a, b))

    def _kinematic_chain(self) -> list:
        """Per Pinocchio joint (in tree order): parent, fixed placement (R, or None for the
        identity, and p), axis and whether it is prismatic, and the q index, multiplier and offset
        that give its angle or displacement (mimic joints follow their source)."""
        axes = _parse_axes(self.urdf_path)
        mimics = {m.name: m for m in self.mimic_joints}
        chain = []
        for index in range(1, self.model.njoints):
            name = self.model.names[index]
            placement = self.model.jointPlacements[index]
            if name in mimics:
                mimic = mimics[name]
                source, multiplier, offset = (
                    self.joint_names.index(mimic.source),
                    mimic.multiplier,
                    mimic.offset,
                )
            else:
                source, multiplier, offset = self.joint_names.index(name), 1.0, 0.0
            rotation = placement.rotation.copy()
            chain.append(
                (
                    index,
                    self.model.parents[index],
                    None if np.allclose(rotation, np.eye(3)) else rotation,
                    placement.translation.copy(),
                    *axes[name],
                    source,
                    multiplier,
                    offset,
                )
            )
        return chain

    def _jacobian_columns(self) -> tuple:
        """How to read data.J, the world-frame spatial Jacobian (6, E) that
        pin.computeJointJacobians leaves: one column per moving joint, mimic joints included (E =
        model.nvExtended), each per unit velocity of the q entry that drives it. Returns
        joint_supports (njoints, E), 1 where a column moves the joint's body, and extended_to_q (E,
        n), which sums the columns into q's."""
        model = self.model
        columns = model.idx_vExtendeds
        supports = np.zeros((model.njoints, model.nvExtended))
        to_q = np.zeros((model.nvExtended, model.nv))
        for joint in range(1, model.njoints):
            supports[joint, [columns[j] for j in model.supports[joint][1:]]] = 1.0
            to_q[columns[joint], model.idx_vs[joint]] = 1.0
        return supports, to_q

    def point_jacobians(self, points: np.ndarray) -> np.ndarray:
        """Linear velocity Jacobians (3, E, k) of world points (k, 3), each as if fixed to the body
        that each column of data.J moves: Jv + Jw x p. Call after pin.computeJointJacobians(model,
        data, q); mask with joint_supports for the joints that move a given body."""
        lever = np.empty((4, len(points)))
        lever[0] = 1.0
        np.negative(points.T, out=lever[1:])
        basis = self.data.J.take(self._cross_index) * _CROSS_SIGNS  # (3, E, 4): Jv, e_c x Jw
        # Jv - sum_c p_c e_c x Jw
        return (basis.reshape(-1, 4) @ lever).reshape(3, -1, len(points))

    def batch_joint_placements(self, configurations: np.ndarray) -> tuple:
        """Vectorized forward kinematics (the same as Pinocchio's) of configurations (B, n):
        ({joint index: rotations (B, 3, 3)}, {joint index: positions (B, 3)}), world frame."""
        qs = np.asarray(configurations, dtype=float)
        batch = qs.shape[0]
        rotations = {0: np.broadcast_to(np.eye(3), (batch, 3, 3))}
        positions = {0: np.zeros((batch, 3))}
        for (
            index,
            parent,
            fixed_rotation,
            fixed_translation,
            axis,
            prismatic,
            source,
            multiplier,
            offset,
        ) in self._chain:
            value = multiplier * qs[:, source] + offset  # rad, or m for a prismatic joint
            parent_rotation = rotations[parent]
            base_rotation = (
                parent_rotation if fixed_rotation is None else parent_rotation @ fixed_rotation
            )
            positions[index] = positions[parent] + parent_rotation @ fixed_translation
            if prismatic:
                positions[index] = positions[index] + (base_rotation @ axis) * value[:, None]
                rotations[index] = np.broadcast_to(base_rotation, (batch, 3, 3))
            else:
                rotations[index] = _rotate_about(base_rotation, axis, value)
        return rotations, positions

    def batch_frame_placements(self, configurations: np.ndarray, frames) -> tuple:
        """World placements of frames for many configurations: configurations (B, n) -> positions
        (B, F, 3) and rotations (B, F, 3, 3) for the F frame names."""
        rotations, positions = self.batch_joint_placements(configurations)
        batch = len(positions[0])
        frame_positions = np.empty((batch, len(frames), 3))
        frame_rotations = np.empty((batch, len(frames), 3, 3))
        for k, name in enumerate(frames):
            frame = self.model.frames[self.frame_id(name)]
            joint, placement = frame.parentJoint, frame.placement
            frame_positions[:, k] = positions[joint] + rotations[joint] @ placement.translation
            frame_rotations[:, k] = rotations[joint] @ placement.rotation
        return frame_positions, frame_rotations

    def closed(self, values, joints, amount):
        """values (k,) of the joints (indices (k,)) moved by amount (>= 0, rad or m; a number or
        (k,)) in the direction that closes each one's finger, within the joint limits."""
        signs = self.closing_signs[joints]
        moved = values + signs * amount
        return np.where(
            signs > 0, np.minimum(moved, self.upper[joints]), np.maximum(moved, self.lower[joints])
        )

    def frame_id(self, name: str) -> int:
        if not self.model.existFrame(name):
            raise ValueError(f"unknown robot frame '{name}'")
        return self.model.getFrameId(name)

    def check_configuration(self, q, what: str = "q", tolerance: float = 1e-9) -> np.ndarray:
        """q as a float array (n,), or ValueError saying what is wrong (size, NaN/inf, limits)."""
        q = np.asarray(q, dtype=float)
        if q.shape != (self.n_joints,):
            raise ValueError(
                f"{what} must have {self.n_joints} joint positions, got shape {q.shape}"
            )
        if not np.all(np.isfinite(q)):
            bad = [self.joint_names[i] for i in np.flatnonzero(~np.isfinite(q))]
            raise ValueError(f"{what} has non-finite values at {', '.join(bad)}")
        outside = np.flatnonzero((q < self.lower - tolerance) | (q > self.upper + tolerance))
        if outside.size:
            i = outside[0]
            raise ValueError(
                f"{what}: {self.joint_names[i]} = {q[i]:.4f} rad is outside its limits "
                f"[{self.lower[i]:.4f}, {self.upper[i]:.4f}]"
                + (f" (and {outside.size - 1} more)" if outside.size > 1 else "")
            )
        return q

    def forward(self, q) -> None:
        """Update joint and frame placements of self.data for configuration q (n,)."""
        pin.framesForwardKinematics(self.model, self.data, np.asarray(q, dtype=float))

    def frame_placement(self, name: str) -> pin.SE3:
        """World placement of a frame after forward(q)."""
        return self.data.oMf[self.frame_id(name)]

    def urdf_joint_positions(self, q) -> dict:
        """Angle of every moving URDF joint (the actuated ones and the mimic ones), by name, rad."""
        angles = dict(zip(self.joint_names, np.asarray(q, dtype=float)))
        for mimic in self.mimic_joints:
            angles[mimic.name] = mimic.multiplier * angles[mimic.source] + mimic.offset
        return angles

    def reach(
        self,
        q,
        frame: str,
        target: pin.SE3,
        iterations: int = 200,
        joints=None,
        damping: float = 1e-3,
        tolerance: float = 1e-5,
    ) -> np.ndarray:
        """Damped least-squares inverse kinematics: a configuration near q placing frame at target.

        Only the given joint indices move (default: the arm). Returns the best configuration found,
        within the joint limits; the caller checks the remaining error if it matters.
        """
        joints = self.arm_indices if joints is None else np.asarray(joints)
        fid = self.frame_id(frame)
        q = np.array(q, dtype=float)
        for _ in range(iterations):
            self.forward(q)
            error = pin.log6(self.data.oMf[fid].actInv(target)).vector
            if np.linalg.norm(error) < tolerance:
                break
            jac = pin.computeFrameJacobian(self.model, self.data, q, fid, pin.LOCAL)[:, joints]
            step = jac.T @ np.linalg.solve(jac @ jac.T + damping * np.eye(6), error)
            q[joints] = np.clip(q[joints] + step, self.lower[joints], self.upper[joints])
        return q


def _rotate_about(rotations: np.ndarray, axis: np.ndarray, angles: np.ndarray) -> np.ndarray:
    """rotations (B, 3, 3) times the rotations about a unit axis (3,) by angles (B,): for a
    coordinate axis only two columns mix (cheap); any other axis uses Rodrigues' formula."""
    cos, sin = np.cos(angles)[:, None], np.sin(angles)[:, None]
    k = int(np.argmax(np.abs(axis)))
    if abs(abs(axis[k]) - 1.0) < 1e-12:
        sin = sin * np.sign(axis[k])
        a, b = (k + 1) % 3, (k + 2) % 3
        out = np.empty(np.broadcast_shapes(rotations.shape, (len(angles), 3, 3)))
        out[:, :, k] = rotations[:, :, k]
        out[:, :, a] = cos * rotations[:, :, a] + sin * rotations[:, :, b]
        out[:, :, b] = cos * rotations[:, :, b] - sin * rotations[:, :, a]
        return out
    x, y, z = axis
    skew = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])
    return rotations @ (
        np.eye(3) + sin[:, :, None] * skew + (1.0 - cos[:, :, None]) * (skew @ skew)
    )
