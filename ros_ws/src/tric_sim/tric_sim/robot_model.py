"""The robot's kinematic and collision model, built once from the URDF and shared by everyone.

The simulator (PyBullet) loads the very same URDF file. Pinocchio parses it with mimic joints, so the
configuration q has the robot's 14 actuated degrees of freedom (7 arm + 7 hand) while the coupled
knuckle of finger 3 follows finger 2's knuckle. Units: m, rad, s.
"""

import pathlib
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

URDF_PATH = pathlib.Path(__file__).resolve().parent / "description" / "tric_arm_hand.urdf"

#: Landmark frames on the robot (paper Fig. 7): palm centre, fingertips, finger bases.
PALM = "palm_center"
FINGERTIPS = ("finger_1_tip", "finger_2_tip", "finger_3_tip")
FINGER_BASES = ("finger_1_base", "finger_2_base", "finger_3_base")
BASE = "base_link"

ARM_JOINTS = tuple(f"arm_{i}_joint" for i in range(1, 8))
HAND_JOINTS = ("finger_1_proximal_joint", "finger_1_distal_joint", "finger_2_knuckle_joint",
               "finger_2_proximal_joint", "finger_2_distal_joint", "finger_3_proximal_joint",
               "finger_3_distal_joint")

#: Home configuration (rad), in the order of RobotModel.joint_names: the hand raised in front of the
#: robot, above the objects' workspace (palm at about (0.30, 0, 0.75) m, facing forward and 45
#: degrees down), fingers slightly open, the knuckle at the three-finger spread (pi/3).
HOME = np.array([0.0, -0.23, 0.0, 1.04, 0.0, 1.54, 0.0,
                 -0.2, 0.2, np.pi / 3, -0.2, 0.2, -0.2, 0.2])


@dataclass(frozen=True)
class MimicJoint:
    """A URDF joint whose angle is multiplier * angle(source) + offset (rad)."""

    name: str
    source: str
    multiplier: float
    offset: float


def _parse_mimics(urdf_path: pathlib.Path) -> tuple:
    root = ET.parse(urdf_path).getroot()
    mimics = []
    for joint in root.iter("joint"):
        tag = joint.find("mimic")
        if tag is not None:
            mimics.append(MimicJoint(joint.get("name"), tag.get("joint"),
                                     float(tag.get("multiplier", 1.0)), float(tag.get("offset", 0.0))))
    return tuple(mimics)


class RobotModel:
    """Pinocchio model, data and collision model of the arm + hand.

    Attributes:
        joint_names: the n = 14 actuated joints, in the order of q.
        lower, upper: joint limits (n,), rad.
        velocity_limits: (n,) rad/s; effort_limits: (n,) N m.
        mimic_joints: URDF joints driven by another joint (not part of q).
    """

    def __init__(self, urdf_path: pathlib.Path = URDF_PATH):
        self.urdf_path = pathlib.Path(urdf_path)
        self.model = pin.buildModelFromUrdf(str(self.urdf_path), mimic=True)
        self.data = self.model.createData()
        self.collision_model = pin.buildGeomFromUrdf(self.model, str(self.urdf_path),
                                                     pin.GeometryType.COLLISION)
        self._add_self_collision_pairs()
        self.collision_data = pin.GeometryData(self.collision_model)
        self.joint_names = tuple(name for name, joint in zip(self.model.names[1:], self.model.joints[1:])
                                 if joint.nq == 1)
        assert len(self.joint_names) == self.model.nq, "one q entry per actuated joint"
        self.lower = self.model.lowerPositionLimit.copy()
        self.upper = self.model.upperPositionLimit.copy()
        self.velocity_limits = self.model.velocityLimit.copy()
        self.effort_limits = self.model.effortLimit.copy()
        self.mimic_joints = _parse_mimics(self.urdf_path)
        self.home = HOME.copy()
        self.arm_indices = np.array([self.joint_names.index(j) for j in ARM_JOINTS])
        self.hand_indices = np.array([self.joint_names.index(j) for j in HAND_JOINTS])

    @property
    def n_joints(self) -> int:
        return self.model.nq

    def _add_self_collision_pairs(self):
        """All pairs of robot geometries except those on the same or on adjacent (parent/child) joints."""
        geoms = self.collision_model.geometryObjects
        parents = self.model.parents
        for a in range(len(geoms)):
            for b in range(a + 1, len(geoms)):
                ja, jb = geoms[a].parentJoint, geoms[b].parentJoint
                if ja == jb or parents[ja] == jb or parents[jb] == ja:
                    continue
                # Siblings on the palm (finger chains' first links, the palm itself) touch by design.
                if parents[ja] == parents[jb] and self.model.names[parents[ja]] == "arm_7_joint":
                    continue
                self.collision_model.addCollisionPair(pin.CollisionPair(a, b))

    def frame_id(self, name: str) -> int:
        if not self.model.existFrame(name):
            raise ValueError(f"unknown robot frame '{name}'")
        return self.model.getFrameId(name)

    def check_configuration(self, q, what: str = "q", tolerance: float = 1e-9) -> np.ndarray:
        """q as a float array (n,), or ValueError saying what is wrong (size, NaN/inf, limits)."""
        q = np.asarray(q, dtype=float)
        if q.shape != (self.n_joints,):
            raise ValueError(f"{what} must have {self.n_joints} joint positions, got shape {q.shape}")
        if not np.all(np.isfinite(q)):
            bad = [self.joint_names[i] for i in np.flatnonzero(~np.isfinite(q))]
            raise ValueError(f"{what} has non-finite values at {', '.join(bad)}")
        outside = np.flatnonzero((q < self.lower - tolerance) | (q > self.upper + tolerance))
        if outside.size:
            i = outside[0]
            raise ValueError(f"{what}: {self.joint_names[i]} = {q[i]:.4f} rad is outside its limits "
                             f"[{self.lower[i]:.4f}, {self.upper[i]:.4f}]"
                             + (f" (and {outside.size - 1} more)" if outside.size > 1 else ""))
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

    def reach(self, q, frame: str, target: pin.SE3, iterations: int = 200,
              joints=None, damping: float = 1e-3, tolerance: float = 1e-5) -> np.ndarray:
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
