"""Task-space features y = phi(q) and their Jacobian dphi/dq (paper Sec. 5.2.1, Eq. 18).

Landmarks are frames: robot frames of the shared Pinocchio model ("robot/<frame>") and objects of
/object_poses ("object/<name>"). For every ordered pair (i, j) of distinct landmarks the features
are the position of j in i's frame (3 numbers) and the distance between them (1 number), all in m:

    p_ij = R_i^T (x_j - x_i),    d_ij = |x_j - x_i|

Grasping uses 8 landmarks (object centre, three fingertips, the middles of the three fingers' lower
segments, palm centre): 56 pairs, 224 features. Box opening uses 5 (box, lid, fingertips of fingers
2 and 3, robot base): 80 features. The lid's landmark is its lip (the middle of its free edge, where
a finger lifts it), not its hinge (docs/decisions/lid-landmark.md).
The Jacobian is analytic, from the frames' Jacobians (objects do not move with q):

    dp_ij/dq = R_i^T (Jv_j - Jv_i) + R_i^T [x_j - x_i]_x Jw_i,
    dd_ij/dq = (x_j - x_i)^T (Jv_j - Jv_i) / d_ij

where Jv, Jw are the world-aligned linear and angular frame Jacobians.
"""

import hashlib
import json
from dataclasses import dataclass
from typing import Any

import numpy as np
import pinocchio as pin

from tric_sim.world.robot_model import RobotModel

#: The tasks with a feature definition (task_landmarks).
TASKS = ("grasp", "open_box")


def task_landmarks(task: str, robot: RobotModel) -> tuple:
    """The landmarks of a task, (name, source) pairs, the robot's frames taken from its profile:
    grasp: the object, each fingertip, the middle of each finger's lower segment, the palm centre,
    and the grasp centre where the profile names one (a parallel gripper's: between its pads);
    open_box: the box, the lid's lip, the fingertips that lift the lid, the robot's base. A
    fingertip is named by its finger's number (thumb first)."""
    if task not in TASKS:
        raise ValueError(f"no feature definition for task '{task}' (known: {', '.join(TASKS)})")
    profile = robot.profile
    fingertips = profile.fingertips
    if task == "grasp":
        return (
            ("object", "object/object"),
            *((f"fingertip_{k}", f"robot/{tip}") for k, tip in enumerate(fingertips, 1)),
            *(
                (f"finger_mid_{k}", f"robot/{mid}")
                for k, mid in enumerate(profile.finger_middles, 1)
            ),
            ("palm", f"robot/{profile.palm}"),
            *(("grasp_centre", f"robot/{centre}") for centre in profile.grasp_centres),
        )
    return (
        ("box", "object/object"),
        ("lid", "object/lid_edge"),
        *(
            (f"fingertip_{fingertips.index(tip) + 1}", f"robot/{tip}")
            for tip in profile.lid_fingertips
        ),
        ("robot_base", f"robot/{profile.base}"),
    )


AXES = ("x", "y", "z")


@dataclass(frozen=True)
class FeatureDefinition:
    """What a feature vector means: the task, the landmarks and where they live, the ordered pairs,
    the joints of the Jacobian's columns, and the robot description (see
    tric_msgs/FeatureDefinition)."""

    task: str
    landmark_names: tuple
    landmark_sources: tuple
    pairs: tuple
    joint_names: tuple
    robot_model: str

    @classmethod
    def for_task(cls, task: str, robot: RobotModel) -> "FeatureDefinition":
        """The paper's definition for task ("grasp" or "open_box"): all ordered landmark pairs."""
        names, sources = zip(*task_landmarks(task, robot))
        pairs = tuple((i, j) for i in range(len(names)) for j in range(len(names)) if i != j)
        return cls(task, names, sources, pairs, tuple(robot.joint_names), robot_description(robot))

    @property
    def feature_names(self) -> tuple:
        names = []
        for i, j in self.pairs:
            a, b = self.landmark_names[i], self.landmark_names[j]
            names += [f"p[{a}->{b}].{axis}" for axis in AXES] + [f"d[{a},{b}]"]
        return tuple(names)

    @property
    def size(self) -> int:
        return 4 * len(self.pairs)

    @property
    def fingerprint(self) -> str:
        """Hex SHA-256 of the canonical JSON of the definition."""
        return hashlib.sha256(json.dumps(self.to_dict(), sort_keys=True).encode()).hexdigest()

    def to_dict(self) -> dict:
        return {
            "task": self.task,
            "landmark_names": list(self.landmark_names),
            "landmark_sources": list(self.landmark_sources),
            "pairs": [list(p) for p in self.pairs],
            "joint_names": list(self.joint_names),
            "robot_model": self.robot_model,
        }

    @classmethod
    def from_dict(cls, data: Any) -> "FeatureDefinition":
        """The definition from to_dict()'s data, or ValueError if it is malformed (data: anything
        read from a file)."""
        try:
            definition = cls(
                str(data["task"]),
                tuple(data["landmark_names"]),
                tuple(data["landmark_sources"]),
                tuple((int(i), int(j)) for i, j in data["pairs"]),
                tuple(data["joint_names"]),
                str(data["robot_model"]),
            )
        except (KeyError, TypeError, ValueError, OverflowError) as error:
            raise ValueError(f"malformed feature definition: {error!r}") from None
        count = len(definition.landmark_names)
        if len(definition.landmark_sources) != count:
            raise ValueError("malformed feature definition: one source per landmark needed")
        if any(not (0 <= i < count and 0 <= j < count and i != j) for i, j in definition.pairs):
            raise ValueError(
                "malformed feature definition: a pair refers to no landmark or twice to one"
            )
        return definition

    def check_same(self, other: "FeatureDefinition", what: str) -> None:
        """ValueError naming what differs, unless other is the same definition."""
        if other.fingerprint == self.fingerprint:
            return
        for field in (
            "task",
            "landmark_names",
            "landmark_sources",
            "pairs",
            "joint_names",
            "robot_model",
        ):
            if getattr(self, field) != getattr(other, field):
                raise ValueError(
                    f"{what} has another feature definition: its {field} differs "
                    f"({getattr(other, field)!r} instead of {getattr(self, field)!r})"
                )


def robot_description(robot: RobotModel) -> str:
    """'<robot profile's name>:<SHA-256 of its URDF>': the robot the landmarks refer to."""
    digest = hashlib.sha256(robot.urdf_path.read_bytes()).hexdigest()
    return f"{robot.profile.name}:{digest}"


class FeatureMap:
    """y = phi(q; object poses) and its Jacobian for a feature definition on the shared robot model.

    One evaluation works on all (i, j) of the L landmarks at once, with few numpy operations (their
    per-call overhead is most of the time): see with_jacobian.
    """

    def __init__(self, definition: FeatureDefinition, robot: RobotModel):
        if definition.robot_model != robot_description(robot):
            made_for = definition.robot_model.split(":")[0]
            raise ValueError(
                f"the feature definition was made for another robot: '{made_for}', not "
                f"'{robot.profile.name}'"
                + (" (the same name, another URDF)" if made_for == robot.profile.name else "")
            )
        if tuple(definition.joint_names) != tuple(robot.joint_names):
            raise ValueError("the feature definition's joints differ from the robot's")
        self.definition, self.robot = definition, robot
        self.robot_landmarks = []  # (landmark index, frame id)
        self.object_landmarks = []  # (landmark index, object name)
        for k, source in enumerate(definition.landmark_sources):
            kind, _, name = source.partition("/")
            if kind == "robot":
                self.robot_landmarks.append((k, robot.frame_id(name)))
            elif kind == "object":
                self.object_landmarks.append((k, name))
            else:
                raise ValueError(
                    f"landmark source '{source}' is neither robot/<frame> nor object/<name>"
                )
        self.object_names = tuple(name for _, name in self.object_landmarks)
        pairs = np.array(definition.pairs)
        self._first, self._second = first, second = pairs[:, 0], pairs[:, 1]
        self._count = count = len(definition.landmark_names)
        self._placements = np.zeros((count, 4, 4))  # landmark poses, homogeneous
        # Rows of the directions (world, unit) that with_jacobian projects the point Jacobians on:
        # 3 i + a: axis a of landmark i (row a of R_i^T); 3 L + 3 i + a: its opposite;
        # 6 L + L i + j: from x_i towards x_j (zero for i = j); the last row: zero.
        self._directions = np.zeros((6 * count + count * count + 1, 3))
        self._axes = self._directions[: 3 * count].reshape(count, 3, 3)
        self._pair = first * count + second
        # R_i^T (x_j - x_k) for all i, (k, j) is (3 L, L L); y's p_ij is at [3 i + a, L i + j]
        self._local_index = (3 * first[:, None] + np.arange(3)) * count * count + self._pair[
            :, None
        ]
        #: (P, E): for each pair, the columns of data.J that move its second landmark only (+1),
        #: its first only (-1), or both or neither (0: they move them rigidly)
        self.relative_supports = self._relative_supports(robot)
        self._jacobian_index, self._extra_jacobian_indices, self.moves_with_q = (
            self._jacobian_indices(robot)
        )
        # object name -> (its xyzw quaternion, rotation matrix)
        self._object_rotations: dict[str, tuple] = {}

    def _relative_supports(self, robot: RobotModel) -> np.ndarray:
        """relative_supports (P, E): the columns of data.J that move each landmark (none for
        objects), and for each pair those that move j relative to i."""
        supports = np.zeros((self._count, robot.joint_supports.shape[1]))
        for k, fid in self.robot_landmarks:
            supports[k] = robot.joint_supports[robot.model.frames[fid].parentJoint]
        return supports[self._second] - supports[self._first]

    def _jacobian_indices(self, robot: RobotModel):
        """Flat indices into with_jacobian's projections (rows of _directions, E columns of data.J,
        L points): (P, 4, n) whose entry [pair, row, c] is the first extended column summed into q's
        column c (RobotModel.extended_to_q), projected on the row's direction with the sign of its
        relative motion, or the zero row; [(c, (P, 4))] the same for the further extended columns of
        the q columns that have more than one (a coupled joint); and which features (d,) move with q
        at all (not those between objects and the robot's fixed base, say)."""
        count, first, second = self._count, self._first, self._second
        columns = robot.joint_supports.shape[1]
        relative = self.relative_supports
        moving_j = np.concatenate(
            [
                3 * first[:, None] + np.arange(3),
                # (P, 4)
                (6 * count + count * first + second)[:, None],
            ],
            axis=1,
        )
        moving_i = np.concatenate(
            [
                3 * count + 3 * first[:, None] + np.arange(3),
                (6 * count + count * second + first)[:, None],
            ],
            axis=1,
        )
        zero_row = 6 * count + count * count
        sources = [np.flatnonzero(robot.extended_to_q[:, c]) for c in range(robot.n_joints)]

        def index(e):
            sign = relative[:, e, None]
            row = np.where(sign > 0, moving_j, np.where(sign < 0, moving_i, zero_row))
            return (row * columns + e) * count + second[:, None]

        first_terms = np.stack([index(extended[0]) for extended in sources], axis=-1)
        extras = [(c, index(e)) for c, extended in enumerate(sources) for e in extended[1:]]
        return first_terms, extras, np.repeat(np.any(relative != 0.0, axis=1), 4)

    @property
    def size(self) -> int:
        return self.definition.size

    def _landmarks(self, q, object_poses: dict, jacobians: bool) -> np.ndarray:
        """Landmark positions (L, 3) (a view of a buffer reused by the next call); writes the
        rotations' transposes into self._axes. With jacobians, robot.data.J is up to date after."""
        placements = self.landmark_placements(q, object_poses, jacobians)
        np.copyto(self._axes, placements[:, :3, :3].transpose(0, 2, 1))
        return placements[:, :3, 3]

    def landmark_placements(self, q, object_poses: dict, jacobians: bool = True) -> np.ndarray:
        """The landmarks' world poses (L, 4, 4), homogeneous, at q (n,) with objects at
        object_poses {name: (p, xyzw)} (a buffer reused by the next call). With jacobians,
        robot.data.J is up to date after (pin.computeJointJacobians)."""
        model, data = self.robot.model, self.robot.data
        if jacobians:
            pin.computeJointJacobians(model, data, q)  # and the joint placements
        else:
            pin.forwardKinematics(model, data, q)
        placements = self._placements
        for k, fid in self.robot_landmarks:
            placements[k] = pin.updateFramePlacement(model, data, fid).homogeneous
        for k, name in self.object_landmarks:
            pose = object_poses.get(name)
            if pose is None:
                raise ValueError(
                    f"object '{name}' is missing from the object poses "
                    f"(have: {', '.join(sorted(object_poses)) or 'none'})"
                )
            placements[k, :3, 3] = pose[0]
            quaternion = tuple(pose[1])
            cached = self._object_rotations.get(name)
            # objects mostly stand still between calls
            if cached is None or cached[0] != quaternion:
                cached = self._object_rotations[name] = (quaternion, _rotation(quaternion))
            placements[k, :3, :3] = cached[1]
        return placements

    def __call__(self, q, object_poses: dict) -> np.ndarray:
        """Features y (d,) at joint positions q (n,) with objects at object_poses {name: (p,
        xyzw)}."""
        positions = self._landmarks(np.asarray(q, dtype=float), object_poses, False)
        return self._features(positions)[0]

    def batch(self, configurations: np.ndarray, object_poses) -> np.ndarray:
        """Features (B, d) of configurations (B, n) (vectorized); object_poses is one dict
        {name: (position, xyzw)} for all, or a list of B such dicts."""
        qs = np.atleast_2d(np.asarray(configurations, dtype=float))
        batch = len(qs)
        positions = np.empty((batch, self._count, 3))
        rotations = np.empty((batch, self._count, 3, 3))
        if self.robot_landmarks:
            indices, frames = zip(*self.robot_landmarks)
            frame_names = [self.robot.model.frames[f].name for f in frames]
            p, r = self.robot.batch_frame_placements(qs, frame_names)
            positions[:, list(indices)], rotations[:, list(indices)] = p, r
        per_configuration = isinstance(object_poses, (list, tuple))
        for k, name in self.object_landmarks:
            poses = object_poses if per_configuration else [object_poses]
            if any(name not in p for p in poses):
                raise ValueError(f"object '{name}' is missing from the object poses")
            positions[:, k] = [p[name][0] for p in poses]
            rotations[:, k] = (
                np.array([_rotation(p[name][1]) for p in poses])
                if per_configuration
                else _rotation(object_poses[name][1])
            )
        out = np.empty((batch, len(self._first), 4))
        for i in np.unique(self._first):
            pairs = np.flatnonzero(self._first == i)
            offsets = positions[:, self._second[pairs]] - positions[:, i, None]  # (B, k, 3) world
            # rows: R_i^T offset
            out[:, pairs, :3] = offsets @ rotations[:, i]
            out[:, pairs, 3] = np.sqrt(np.sum(offsets * offsets, axis=2))
        return out.reshape(batch, -1)

    def with_jacobian(self, q, object_poses: dict):
        """(y (d,), dy/dq (d, n)) at q (n,).

        With V_j = Jv + Jw x x_j, the velocity Jacobian of the point x_j as if fixed to the body
        each column of data.J moves, the columns moving both landmarks move them rigidly and cancel:

            dp_ij/dq = s R_i^T V_j,    dd_ij/dq = s (x_j - x_i)^T V_j / d_ij

        column by column, with s = +1 where the column moves j only, -1 where it moves i only, 0
        elsewhere. One product projects every V_j on every direction of _directions; the Jacobian's
        entries are then taken out of it (with the sign, and summed into q's columns) by index.
        """
        positions = self._landmarks(np.asarray(q, dtype=float), object_poses, True)
        y, offsets, distances = self._features(positions)
        count, directions = self._count, self._directions
        np.negative(directions[: 3 * count], out=directions[3 * count : 6 * count])
        np.divide(
            offsets.reshape(-1, 3),
            np.maximum(distances, 1e-12).reshape(-1, 1),
            out=directions[6 * count : -1],
        )
        # (rows, E L)
        projections = directions @ self.robot.point_jacobians(positions).reshape(3, -1)
        # (P, 4, n)
        jacobian = projections.take(self._jacobian_index)
        for column, index in self._extra_jacobian_indices:
            jacobian[:, :, column] += projections.take(index)
        return y, jacobian.reshape(-1, self.robot.n_joints)

    def _features(self, positions):
        """(y (d,), x_j - x_i (L, L, 3), d_ij (L, L)) of landmark positions (L, 3), for all (i, j),
        with the landmarks' R_i^T in self._axes."""
        # [i, j]: x_j - x_i
        offsets = positions[None, :, :] - positions[:, None, :]
        y = np.empty((len(self._first), 4))
        # R_i^T (x_j - x_k)
        local = self._directions[: 3 * self._count] @ offsets.reshape(-1, 3).T
        local.take(self._local_index, out=y[:, :3])
        distances = np.sqrt(np.einsum("ija,ija->ij", offsets, offsets))
        distances.take(self._pair, out=y[:, 3])
        return y.reshape(-1), offsets, distances


def _rotation(quaternion) -> np.ndarray:
    """Rotation matrix of an xyzw quaternion (normalized here)."""
    x, y, z, w = quaternion
    norm = (x * x + y * y + z * z + w * w) ** 0.5
    if not norm > 0:
        raise ValueError(f"object orientation {tuple(quaternion)} is not a valid quaternion")
    x, y, z, w = x / norm, y / norm, z / norm, w / norm
    return np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
