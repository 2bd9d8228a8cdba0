"""Collision checking of the robot against a situation's scene, with coal through the shared model.

The robot's collision geometry is the URDF's (the Pinocchio GeometryModel of RobotModel); the
scene's is tric_sim.scene's bodies as coal primitives. Checking many configurations at once (the
noisy samples of TRIC's training) is vectorized: each robot geometry is covered by a few bounding
spheres, whose distances to the scene bodies and to each other are computed for all configurations
in numpy; coal then computes the exact distance only for the (configuration, geometry pair)
combinations whose bounding spheres come close. Units: m.
"""

import math
from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from tric_sim import metrics, scene
from tric_sim.robot_model import RobotModel
from tric_sim.situations import Situation

#: Penetration allowed into the bodies the hand may touch (the grasp target, the lid), m: the fingers
#: of a firm grasp press a few millimetres into it in simulation.
TOUCH_TOLERANCE = 0.005
#: The role of a pair of the hand with a scene body the hand may press (see ClosePair).
HAND_ROLES = {"target": "touch", "lid": "push"}


def coal_shape(shape: str, dimensions):
    """A coal primitive: box (full extents), sphere (radius,), cylinder (height, radius)."""
    if shape == "box":
        return coal.Box(*dimensions)
    if shape == "sphere":
        return coal.Sphere(dimensions[0])
    height, radius = dimensions
    return coal.Cylinder(radius, height)


def _bounding_spheres(geometry) -> list:
    """Spheres (centre in the geometry's frame (3,), radius) that together cover a cylinder or
    sphere (or, for anything else, one sphere around its local AABB)."""
    shape = geometry
    if isinstance(shape, coal.Sphere):
        return [(np.zeros(3), shape.radius)]
    if isinstance(shape, coal.Cylinder):
        length = 2 * shape.halfLength
        count = max(1, math.ceil(length / (2 * shape.radius)))
        half_piece = length / count / 2
        radius = math.hypot(shape.radius, half_piece)
        return [(np.array([0.0, 0.0, -length / 2 + half_piece * (2 * k + 1)]), radius) for k in range(count)]
    shape.computeLocalAABB()
    box = shape.aabb_local
    centre = (np.array(box.min_) + np.array(box.max_)) / 2
    return [(centre, float(np.linalg.norm(np.array(box.max_) - centre)))]


class SceneCollision:
    """The robot and one situation's scene.

    collision_free(configurations, object_poses) tells, for each configuration, whether the robot
    (but its base, which is mounted on the table) is clear of the table, obstacles and box body, penetrates the grasp target or lid by no more than
    TOUCH_TOLERANCE, and does not collide with itself (non-adjacent links).
    """

    def __init__(self, robot: RobotModel, situation: Situation):
        self.robot = robot
        self.bodies = scene.scene_bodies(situation)
        self.situation = situation
        geometry_model = robot.collision_model
        self.robot_geometries = [(g.parentJoint, g.placement, g.geometry) for g in geometry_model.geometryObjects]
        # geometry fixed to the world (the base, mounted on the table) is not checked against the scene
        self._moving = np.array([joint != 0 for joint, _, _ in self.robot_geometries])
        self.self_pairs = [(p.first, p.second) for p in geometry_model.collisionPairs]
        self.body_shapes = [coal_shape(b.shape, b.dimensions) for b in self.bodies]
        self.allowance = [TOUCH_TOLERANCE if b.role in ("target", "lid") else 0.0 for b in self.bodies]
        # bounding spheres: (geometry index, centre in the joint frame, radius)
        self.spheres = []
        for k, (_, placement, shape) in enumerate(self.robot_geometries):
            for centre, radius in _bounding_spheres(shape):
                self.spheres.append((k, placement.act(centre), radius))
        self._sphere_geometry = np.array([s[0] for s in self.spheres])
        self._sphere_radius = np.array([s[2] for s in self.spheres])
        # every pair of bounding spheres of every self-collision pair: (first, second, pair index)
        combos = [(i, j, k) for k, (a, c) in enumerate(self.self_pairs)
                  for i in np.flatnonzero(self._sphere_geometry == a)
                  for j in np.flatnonzero(self._sphere_geometry == c)]
        self._combo_first, self._combo_second, self._combo_pair = (np.array(v) for v in zip(*combos))
        self._combo_reach = self._sphere_radius[self._combo_first] + self._sphere_radius[self._combo_second]
        self._pair_starts = np.flatnonzero(np.r_[True, np.diff(self._combo_pair) != 0])
        self._functors = {}
        self._request = coal.DistanceRequest()
        self._result = coal.DistanceResult()

    def body_placements(self, object_poses: dict, bodies=None) -> list:
        """World placement of each scene body's geometry (of bodies, default all); the object and lid
        follow object_poses (name -> (position, xyzw)) where given."""
        placements = []
        for body in self.bodies if bodies is None else bodies:
            pose = object_poses.get(body.name, (body.position, body.orientation))
            placement = scene.se3(*pose)
            if body.role == "lid":
                placement = placement * scene.lid_geometry_offset(self.situation.object_dimensions[0])
            placements.append(placement)
        return placements

    def collision_free(self, configurations: np.ndarray, object_poses: dict) -> np.ndarray:
        """Boolean mask (B,) over configurations (B, n)."""
        qs = np.asarray(configurations, dtype=float).reshape(-1, self.robot.n_joints)
        if len(qs) == 0:
            return np.zeros(0, dtype=bool)
        rotations, positions = self.robot.batch_joint_placements(qs)
        joints = [self.robot_geometries[k][0] for k, _, _ in self.spheres]
        centres = np.stack([positions[j] + rotations[j] @ c for j, (_, c, _) in zip(joints, self.spheres)], 1)
        placements = self.body_placements(object_poses)
        free = np.ones(len(qs), dtype=bool)
        suspects = []  # (configuration, robot geometry, body index or None, other robot geometry or None)
        for b, (body, placement) in enumerate(zip(self.bodies, placements)):
            for geometry, (joint, local, shape) in enumerate(self.robot_geometries):
                if not self._moving[geometry]:
                    continue
                exact = self._exact_distance(shape, rotations[joint], positions[joint], local, body, placement)
                if exact is not None:
                    free &= exact >= -self.allowance[b]
                    continue
                spheres = np.flatnonzero(self._sphere_geometry == geometry)
                clearance = _body_distance(body, placement, centres[:, spheres].reshape(-1, 3))
                near = np.flatnonzero((clearance.reshape(len(qs), -1) - self._sphere_radius[spheres] < 1e-3).any(axis=1)
                                      & free)
                if len(near) and isinstance(shape, coal.Cylinder):
                    solid = _Cylinder.of(shape, rotations[joint][near], positions[joint][near], local)
                    near = near[~solid.separated_from(_body_solid(body, placement, len(near)))]
                suspects += [(config, geometry, b, None) for config in near]
        by_sphere = np.ascontiguousarray(centres.transpose(1, 2, 0))           # (spheres, 3, B)
        offsets = by_sphere[self._combo_first] - by_sphere[self._combo_second]  # (combos, 3, B)
        squared = offsets[:, 0] ** 2 + offsets[:, 1] ** 2 + offsets[:, 2] ** 2
        close = squared < ((self._combo_reach + 1e-3) ** 2)[:, None]           # (combos, B)
        close_pairs = np.maximum.reduceat(close, self._pair_starts, axis=0).T  # (B, self pairs)
        for pair in np.flatnonzero(close_pairs.any(axis=0)):
            a, c = self.self_pairs[self._combo_pair[self._pair_starts[pair]]]
            near = np.flatnonzero(close_pairs[:, pair] & free)
            (ja, la, sa), (jc, lc, sc) = self.robot_geometries[a], self.robot_geometries[c]
            if len(near) and isinstance(sa, coal.Cylinder) and isinstance(sc, coal.Cylinder):
                first = _Cylinder.of(sa, rotations[ja][near], positions[ja][near], la)
                second = _Cylinder.of(sc, rotations[jc][near], positions[jc][near], lc)
                near = near[~first.separated_from(second)]
            suspects += [(config, a, None, c) for config in near]
        for config, geometry, body, other in suspects:
            if not free[config]:
                continue
            if body is not None:
                other_shape, other_rotation, other_translation = (
                    self.body_shapes[body], placements[body].rotation, placements[body].translation)
                allowance = self.allowance[body]
            else:
                other_shape, other_rotation, other_translation = self._world(other, rotations, positions, config)
                allowance = 0.0
            shape = self.robot_geometries[geometry][2]
            rotation, translation = self._world(geometry, rotations, positions, config)[1:]
            key = (id(shape), id(other_shape))
            functor = self._functors.get(key)
            if functor is None:
                functor = self._functors[key] = coal.ComputeDistance(shape, other_shape)
            self._result.clear()
            distance = functor(coal.Transform3s(rotation, translation),
                               coal.Transform3s(other_rotation, other_translation), self._request, self._result)
            free[config] = distance >= -allowance
        return free

    def _world(self, geometry, rotations, positions, config):
        """(shape, world rotation, world translation) of a robot geometry in one configuration."""
        joint, local, shape = self.robot_geometries[geometry]
        rotation = rotations[joint][config]
        return shape, rotation @ local.rotation, positions[joint][config] + rotation @ local.translation

    @staticmethod
    def _exact_distance(shape, rotations, positions, local: pin.SE3, body: scene.Body, placement: pin.SE3):
        """Exact signed distances (B,) between a robot sphere and any body, or a robot cylinder and a
        spherical body, from the closed-form distance to the other's surface; None otherwise."""
        centres = positions + rotations @ local.translation
        if isinstance(shape, coal.Sphere):
            return _body_distance(body, placement, centres) - shape.radius
        if isinstance(shape, coal.Cylinder) and body.shape == "sphere":
            # the sphere's centre in each cylinder's frame, against the cylinder's surface
            axes = rotations @ local.rotation
            relative = np.einsum("bji,bj->bi", axes, placement.translation - centres)
            cylinder = pin.SE3.Identity()
            distance, _ = metrics.object_surface("cylinder", (2 * shape.halfLength, shape.radius), cylinder, relative)
            return distance - body.dimensions[0]
        return None


@dataclass
class ClosePair:
    """A robot geometry near something it must not penetrate: signed distance (m), the row (n,)
    that maps a joint step dq to the change of that distance (n^T J at the witness points), and the
    other's role: a scene body's ("table", "obstacle", "box_body", "target", "lid"), "touch" for the
    hand against the grasp target (which it may press to grip), "push" for the hand beneath the lid
    (which it must push open), or "self" (another robot part)."""

    name: str
    distance: float
    row: np.ndarray
    role: str = "self"


class Proximity:
    """Distances for a controller, one configuration at a time: the robot geometries near the
    scene bodies they must avoid, and arm geometries near other robot geometries.

    Every robot geometry is checked against every scene body; pairs of the hand (palm and fingers)
    with the grasp target get the role "touch", with the lid "push" (the hand may press them), but
    only while the hand is beneath the lid: a lid opens upwards, so pressing it from above can only
    shut it, and there it is a body to keep clear of ("lid"). Pairs inside the hand are left to its
    joint limits (fingers touching each other do no harm).

    The scene bodies are added to a copy of the robot's collision model (fixed to the world), with
    one collision pair per (moving robot geometry, body) and per self pair, so that Pinocchio places
    every geometry and runs coal on a pair in one call each.
    """

    def __init__(self, robot: RobotModel, situation: Situation):
        self.robot = robot
        self.scene = SceneCollision(robot, situation)
        model = robot.model
        objects = robot.collision_model.geometryObjects
        self.hand = np.array([model.frames[g.parentFrame].name.startswith(("finger_", "palm")) for g in objects])
        self.names = [g.name for g in objects]
        self.bound = np.array([max(np.linalg.norm(c) + r for c, r in _bounding_spheres(shape))
                               for _, _, shape in self.scene.robot_geometries])
        self.self_pairs = np.array([(a, b) for a, b in self.scene.self_pairs if not (self.hand[a] and self.hand[b])])
        count, bodies = len(objects), len(self.scene.bodies)
        self.geometry_model = pin.GeometryModel()
        for geometry in objects:
            self.geometry_model.addGeometryObject(geometry)
        self._body_placements = self.scene.body_placements({})
        self._body_poses = [None] * bodies  # the object_poses entry each placement was made from
        for body, shape, placement in zip(self.scene.bodies, self.scene.body_shapes, self._body_placements):
            self.geometry_model.addGeometryObject(pin.GeometryObject(f"scene/{body.name}", 0, 0, placement, shape))
        # collision pairs: (robot geometry k, body b) for every k (pair k * bodies + b), then the self
        # pairs; their names, roles, and the joints moving their two sides (0: the world)
        self._names, self._roles, joints = [], [], []
        for k in range(count):
            for b, body in enumerate(self.scene.bodies):
                self.geometry_model.addCollisionPair(pin.CollisionPair(k, count + b))
                self._names.append(f"{self.names[k]}/{body.name}")
                self._roles.append(HAND_ROLES.get(body.role, body.role) if self.hand[k] else body.role)
                joints.append((objects[k].parentJoint, 0))
        for a, b in self.self_pairs.tolist():
            self.geometry_model.addCollisionPair(pin.CollisionPair(a, b))
            self._names.append(f"{self.names[a]}/{self.names[b]}")
            self._roles.append("self")
            joints.append((objects[a].parentJoint, objects[b].parentJoint))
        self.geometry_data = pin.GeometryData(self.geometry_model)
        for pair in range(len(self.geometry_model.collisionPairs)):
            # coal's default request (Pinocchio's warm-starts GJK from the pair's previous call)
            self.geometry_data.distanceRequests[pair] = coal.DistanceRequest()
        self._geometry_count, self._body_count = count, bodies
        self._supports = robot.joint_supports[np.array(joints)]   # (pairs, 2, E): data.J's columns moving each side

    def _update_bodies(self, object_poses: dict) -> None:
        """Move the bodies that object_poses (name -> (position, xyzw)) places elsewhere than before."""
        for b, body in enumerate(self.scene.bodies):
            pose = object_poses.get(body.name)
            if pose is None:
                continue
            key = (tuple(pose[0]), tuple(pose[1]))
            if key != self._body_poses[b]:
                placement = self.scene.body_placements({body.name: pose}, [body])[0]
                self._body_placements[b] = placement
                self.geometry_model.geometryObjects[self._geometry_count + b].placement = placement
                self._body_poses[b] = key

    def near(self, q: np.ndarray, object_poses: dict, influence: float) -> list:
        """ClosePairs within influence (m), closest first."""
        model, data = self.robot.model, self.robot.data
        self._update_bodies(object_poses)
        pin.computeJointJacobians(model, data, q)
        pin.updateGeometryPlacements(model, data, self.geometry_model, self.geometry_data)
        centres = np.array([placement.translation
                            for placement in self.geometry_data.oMg.tolist()[:self._geometry_count]])
        # candidates: pairs whose geometries' bounding spheres come within influence
        candidates = []
        for b, (body, placement) in enumerate(zip(self.scene.bodies, self._body_placements)):
            clearance = _body_distance(body, placement, centres) - self.bound
            candidates += (np.flatnonzero(self.scene._moving & (clearance < influence)) * self._body_count + b).tolist()
        if len(self.self_pairs):
            a, b = self.self_pairs[:, 0], self.self_pairs[:, 1]
            offsets = centres[a] - centres[b]
            gaps = np.sqrt(np.einsum("ka,ka->k", offsets, offsets)) - self.bound[a] - self.bound[b]
            candidates += (np.flatnonzero(gaps < influence) + self._geometry_count * self._body_count).tolist()
        close, distances, points, normals = [], [], [], []
        for pair in candidates:
            result = pin.computeDistance(self.geometry_model, self.geometry_data, pair)
            if result.min_distance < influence:
                close.append(pair)
                distances.append(result.min_distance)
                points.append(result.getNearestPoint1())
                normals.append(result.normal)  # from the first geometry towards the second
        if not close:
            return []
        aways = -np.array(normals)
        rows = self._rows(close, np.array(distances), np.array(points), aways)
        roles = [self._roles[pair] if self._roles[pair] != "push" else self._push_role(pair, away)
                 for pair, away in zip(close, aways)]
        return sorted((ClosePair(self._names[pair], distance, row, role)
                       for pair, distance, row, role in zip(close, distances, rows, roles)),
                      key=lambda p: p.distance)

    def _push_role(self, pair: int, away: np.ndarray) -> str:
        """The role of a hand-lid pair at the moment: "push", or "lid" where its hand side moves away
        from the lid along the lid's normal (unit away (3,), world frame), i.e. is above the lid."""
        lid = self._body_placements[pair % self._body_count]
        return "lid" if away @ lid.rotation[:, 2] > 0.0 else "push"

    def _rows(self, pairs: list, distances: np.ndarray, points: np.ndarray, aways: np.ndarray) -> np.ndarray:
        """The rows (k, n) that map a joint step to the change of the pairs' distances (k,): the
        unit directions aways (k, 3) in which the first sides move away from the second, on the
        velocities of the witness points (k, 3) on the first sides minus those of the second sides'
        (at distance along -away), each point fixed to its side's body (the world's does not move)."""
        others = points - aways * distances[:, None]
        velocities = self.robot.point_jacobians(np.concatenate([points, others]))      # (3, E, 2 k)
        along = np.einsum("ka,aek->ke", np.concatenate([aways, -aways]), velocities)    # (2 k, E)
        supports = self._supports[pairs]                                               # (k, 2, E)
        count = len(pairs)
        return (along[:count] * supports[:, 0] + along[count:] * supports[:, 1]) @ self.robot.extended_to_q


def _body_distance(body: scene.Body, placement: pin.SE3, points: np.ndarray) -> np.ndarray:
    """Signed distance (k,) of points (k, 3) to a scene body's surface."""
    if body.shape == "sphere":
        offsets = points - placement.translation
        return np.sqrt(np.einsum("ka,ka->k", offsets, offsets)) - body.dimensions[0]
    if body.shape == "cylinder":
        return metrics.object_surface(body.shape, body.dimensions, placement, points)[0]
    local = (points - placement.translation) @ placement.rotation
    q = np.abs(local) - np.asarray(body.dimensions) / 2
    outside = np.maximum(q, 0.0)
    return np.sqrt(np.einsum("ka,ka->k", outside, outside)) + np.minimum(q.max(axis=1), 0.0)


class _Cylinder:
    """Cylinders for separating-axis tests, vectorized over configurations: centres (B, 3), unit
    axes (B, 3), half lengths and radii (scalars)."""

    def __init__(self, centres, axes, half_length, radius):
        self.centres, self.axes, self.half_length, self.radius = centres, axes, half_length, radius

    @classmethod
    def of(cls, shape, joint_rotations, joint_positions, local: pin.SE3) -> "_Cylinder":
        centres = joint_positions + joint_rotations @ local.translation
        axes = joint_rotations @ local.rotation[:, 2]
        return cls(centres, axes, shape.halfLength, shape.radius)

    def half_extent(self, directions: np.ndarray) -> np.ndarray:
        """Half the length of the cylinders' projections on unit directions (B, 3)."""
        along = np.abs(np.einsum("bi,bi->b", self.axes, directions))
        return along * self.half_length + self.radius * np.sqrt(np.maximum(1.0 - along ** 2, 0.0))

    def separated_from(self, other) -> np.ndarray:
        """(B,) True where a separating axis proves the two solids apart: the cylinders' axes and,
        for a box, its face normals."""
        axes = [self.axes] + other.axes_to_test()
        if isinstance(other, _Cylinder):
            axes.append(other.axes)
        offset = other.centres - self.centres
        apart = np.zeros(len(offset), dtype=bool)
        for direction in axes:
            gap = np.abs(np.einsum("bi,bi->b", offset, direction))
            apart |= gap > self.half_extent(direction) + other.half_extent(direction)
        return apart

    def axes_to_test(self) -> list:
        return []


class _Box:
    """An oriented box repeated for B configurations (the scene's bodies do not move with q)."""

    def __init__(self, placement: pin.SE3, extents, count: int):
        self.centres = np.broadcast_to(placement.translation, (count, 3))
        self.normals = [np.broadcast_to(placement.rotation[:, k], (count, 3)) for k in range(3)]
        self.half = np.asarray(extents) / 2

    def half_extent(self, directions: np.ndarray) -> np.ndarray:
        return sum(np.abs(np.einsum("bi,bi->b", n, directions)) * h for n, h in zip(self.normals, self.half))

    def axes_to_test(self) -> list:
        return list(self.normals)


def _body_solid(body: scene.Body, placement: pin.SE3, count: int):
    """A scene body as a solid for separating-axis tests (spheres are handled exactly elsewhere)."""
    if body.shape == "box":
        return _Box(placement, body.dimensions, count)
    height, radius = body.dimensions
    return _Cylinder(np.broadcast_to(placement.translation, (count, 3)),
                     np.broadcast_to(placement.rotation[:, 2], (count, 3)), height / 2, radius)
