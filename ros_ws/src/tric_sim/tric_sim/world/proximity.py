"""The controller's collision queries, one configuration at a time, tick after tick: the pairs of
robot geometries and scene bodies (or other robot geometries) within reach, their distances and the
rows that map a joint step to the change of each distance.

Proximity keeps, for every pair, a lower bound of its distance, lowered each call by how far the
joints' motion since the last call can have moved the pair's two sides (and a scene body, if it
moved); only the pairs whose bound falls within reach go to coal, which resets their bound to their
distance. Units: m, rad.
"""

import math
from dataclasses import dataclass

import coal
import numpy as np
import pinocchio as pin

from tric_sim.world import shapes
from tric_sim.world.collision import SceneCollision
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation import Situation

#: Proximity sends a pair to coal when its distance's lower bound is below the reach asked for plus
#: this, m (room for coal's own tolerance).
BOUND_SLACK = 1e-4


@dataclass
class Closest:
    """The pairs of a Proximity within reach of one configuration, closest first, k of them.

    pairs (k,): indices into pair_names ("<robot geometry>/<scene body or robot geometry>").
    distances (k,): signed distances, m.
    rows (k, n): the gradients of the distances in q: row @ dq is the change of a distance for a
        joint step dq (n^T J at the witness points).
    aways (k, 3): unit directions, world frame, in which the robot side of each pair moves away
        from the other side.
    bodies (k,): the scene body of each pair (index into body_names), -1 for a pair within the
    robot. hand (k,): whether the robot side of each pair is part of the hand (palm or fingers).
    body_names (B,), body_rotations (B, 3, 3): the scene's bodies and their solids' world rotations.
    """

    pairs: np.ndarray
    distances: np.ndarray
    rows: np.ndarray
    aways: np.ndarray
    bodies: np.ndarray
    hand: np.ndarray
    pair_names: list
    body_names: tuple
    body_rotations: np.ndarray

    @classmethod
    def none(cls, n_joints: int, pair_names=(), body_names=(), body_rotations=None) -> "Closest":
        """No pair within reach (of a scene with these tables, default none)."""
        return cls(
            np.zeros(0, dtype=int),
            np.zeros(0),
            np.zeros((0, n_joints)),
            np.zeros((0, 3)),
            np.zeros(0, dtype=int),
            np.zeros(0, dtype=bool),
            pair_names,
            body_names,
            np.zeros((0, 3, 3)) if body_rotations is None else body_rotations,
        )

    def __len__(self) -> int:
        return len(self.pairs)

    def names(self, selected) -> list:
        """The names of the pairs at indices (or a boolean mask) selected into this result."""
        return [self.pair_names[pair] for pair in self.pairs[selected].tolist()]


class Proximity:
    """Distances for a controller, one configuration at a time: the robot geometries near the
    scene bodies, and arm geometries near other robot geometries (pairs inside the hand are left to
    its joint limits: fingers touching each other do no harm). What may be touched is the caller's
    business: contacts holds the situation's task's (tric_sim.world.scene.contacts), and each pair
    says which body it is with and whether its robot side is the hand.

    The scene bodies are added to a copy of the robot's collision model (fixed to the world), with
    one collision pair per (robot geometry, body) and per self pair, so that Pinocchio places every
    geometry and runs coal on a pair in one call each. Geometry fixed to the world (the base,
    mounted on the table) is not checked against the scene.
    """

    def __init__(self, robot: RobotModel, situation: Situation):
        self.robot = robot
        self.scene = SceneCollision(robot, situation)
        self.contacts = self.scene.contacts
        objects = robot.collision_model.geometryObjects
        self.hand = robot.hand_geometries
        self.names = [g.name for g in objects]
        bounds = [
            max(np.linalg.norm(c) + r for c, r in shapes.bounding_spheres(shape))
            for _, _, shape in self.scene.robot_geometries
        ]
        self.self_pairs = np.array(
            [(a, b) for a, b in self.scene.self_pairs if not (self.hand[a] and self.hand[b])]
        )
        count, bodies = len(objects), len(self.scene.bodies)
        self.body_names = tuple(body.name for body in self.scene.bodies)
        self.geometry_model = pin.GeometryModel()
        for geometry in objects:
            self.geometry_model.addGeometryObject(geometry)
        self._body_placements = self.scene.body_placements({})
        # the pose (position, xyzw) each body's placement was made from
        self._body_poses = [
            (tuple(body.position), tuple(body.orientation)) for body in self.scene.bodies
        ]
        self._body_rotations = np.array([placement.rotation for placement in self._body_placements])
        for body, shape, placement in zip(
            self.scene.bodies, self.scene.body_shapes, self._body_placements
        ):
            self.geometry_model.addGeometryObject(
                pin.GeometryObject(f"scene/{body.name}", 0, 0, placement, shape)
            )
        # collision pairs: (robot geometry k, body b) for every k (pair k * bodies + b), then the
        # self pairs; their names, bodies (-1: none), hands, and the joints moving their two sides
        # (0: the world)
        self.pair_names, pair_bodies, pair_hand, joints = [], [], [], []
        for k in range(count):
            for b, body in enumerate(self.scene.bodies):
                self.geometry_model.addCollisionPair(pin.CollisionPair(k, count + b))
                self.pair_names.append(f"{self.names[k]}/{body.name}")
                pair_bodies.append(b)
                pair_hand.append(self.hand[k])
                joints.append((objects[k].parentJoint, 0))
        for a, b in self.self_pairs.tolist():
            self.geometry_model.addCollisionPair(pin.CollisionPair(a, b))
            self.pair_names.append(f"{self.names[a]}/{self.names[b]}")
            pair_bodies.append(-1)
            pair_hand.append(False)
            joints.append((objects[a].parentJoint, objects[b].parentJoint))
        self.geometry_data = pin.GeometryData(self.geometry_model)
        for pair in range(len(self.geometry_model.collisionPairs)):
            # coal's default request (Pinocchio's warm-starts GJK from the pair's previous call)
            self.geometry_data.distanceRequests[pair] = coal.DistanceRequest()
        self._pair_bodies, self._pair_hand = np.array(pair_bodies), np.array(pair_hand)
        # data.J's columns moving each pair's first sides (rows 0 to P - 1) and second sides (P to 2
        # P - 1)
        self._side_supports = np.concatenate(
            robot.joint_supports[np.array(joints)].transpose(1, 0, 2)
        )
        # the order in which pairs are examined (and ties in distance kept): body by body, geometry
        # by geometry, then the self pairs; pairs of geometry mounted on the table never
        moving = ~robot.mounted_geometries
        self._order = np.array(
            [k * bodies + b for b in range(bodies) for k in range(count) if moving[k]]
            + list(range(count * bodies, len(self.pair_names))),
            dtype=int,
        )
        # how far a unit motion of each q entry can move each pair's two sides together, m/rad
        reach = _geometry_reach(robot, objects, bounds)  # (geometries, n)
        self._pair_reach = np.concatenate(
            [
                np.repeat(reach, bodies, axis=0),
                reach[self.self_pairs[:, 0]] + reach[self.self_pairs[:, 1]],
            ]
        )
        self._body_pairs = [np.arange(b, count * bodies, bodies) for b in range(bodies)]
        # how far from its frame's origin a point of each body's solid may be, m
        self._body_reach = [
            shapes.bounding_radius(body.shape, body.dimensions)
            + (math.hypot(*body.geometry_offset[0]) if body.geometry_offset else 0.0)
            for body in self.scene.bodies
        ]
        self._lower_bounds = np.full(len(self.pair_names), -np.inf)
        self._wrenches = np.empty((2 * len(self.pair_names), 6))
        self._checked_at = None  # the configuration the lower bounds hold for
        self._geometry_count, self._body_count = count, bodies

    def _update_bodies(self, object_poses: dict) -> None:
        """Move the bodies that object_poses (name -> (position, xyzw)) places elsewhere than
        before, lowering their pairs' bounds by how far any point of their solids can have moved:
        the translation plus the rotation's largest displacement of a point at the solid's reach,
        from the quaternions (|R1 - R0| <= 2 min(|q1 - q0|, |q1 + q0|) for unit quaternions)."""
        for b, body in enumerate(self.scene.bodies):
            pose = object_poses.get(body.name)
            if pose is None:
                continue
            position, orientation = tuple(pose[0]), tuple(pose[1])
            before_position, before_orientation = self._body_poses[b]
            if position == before_position and orientation == before_orientation:
                continue
            x, y, z, w = orientation
            x0, y0, z0, w0 = before_orientation
            turned = 2.0 * min(
                math.dist(orientation, before_orientation),
                math.hypot(x + x0, y + y0, z + z0, w + w0),
            )
            self._lower_bounds[self._body_pairs[b]] -= (
                math.dist(position, before_position) + turned * self._body_reach[b]
            )
            placement = body.solid_placement(pose)
            self._body_placements[b] = placement
            self._body_rotations[b] = placement.rotation
            self.geometry_model.geometryObjects[self._geometry_count + b].placement = placement
            self._body_poses[b] = (position, orientation)

    def near(self, q: np.ndarray, object_poses: dict, influence: float) -> Closest:
        """The pairs within influence (m) of each other at q (n,), with the objects at object_poses
        (name -> (position, xyzw)), closest first."""
        model, data = self.robot.model, self.robot.data
        q = np.asarray(q, dtype=float)
        self._update_bodies(object_poses)
        bounds = self._lower_bounds
        if self._checked_at is not None:
            bounds -= self._pair_reach @ np.abs(q - self._checked_at)
        self._checked_at = q.copy()
        pin.computeJointJacobians(model, data, q)
        pin.updateGeometryPlacements(model, data, self.geometry_model, self.geometry_data)
        # (a NaN bound, after a non-finite q, sends its pair to coal)
        candidates = self._order[~(bounds.take(self._order) >= influence + BOUND_SLACK)].tolist()
        # the pairs within influence, their distances and witness points: lists, then arrays
        close: list | np.ndarray
        distances: list | np.ndarray
        points: list | np.ndarray
        close, distances, points, normals, checked = [], [], [], [], []
        geometry_model, geometry_data, compute = (
            self.geometry_model,
            self.geometry_data,
            pin.computeDistance,
        )
        for pair in candidates:
            result = compute(geometry_model, geometry_data, pair)
            distance = result.min_distance
            checked.append(distance)
            if distance < influence:
                close.append(pair)
                distances.append(distance)
                points.append(result.getNearestPoint1())
                normals.append(result.normal)  # from the first geometry towards the second
        bounds[candidates] = checked
        if not close:
            return Closest.none(
                self.robot.n_joints, self.pair_names, self.body_names, self._body_rotations
            )
        close, distances = np.array(close), np.array(distances)
        points, aways = np.array(points), np.array(normals)
        np.negative(aways, out=aways)
        if len(close) > 1:  # closest first; ties keep the examination order
            order = distances.argsort(kind="stable")
            close, distances = close.take(order), distances.take(order)
            points, aways = points.take(order, axis=0), aways.take(order, axis=0)
        return Closest(
            close,
            distances,
            self._rows(close, distances, points, aways),
            aways,
            self._pair_bodies.take(close),
            self._pair_hand.take(close),
            self.pair_names,
            self.body_names,
            self._body_rotations,
        )

    def _rows(
        self, pairs: np.ndarray, distances: np.ndarray, points: np.ndarray, aways: np.ndarray
    ) -> np.ndarray:
        """The rows (k, n) that map a joint step to the change of the pairs' distances (k,): the
        unit directions aways (k, 3) in which the first sides move away from the second, on the
        velocities of the witness points (k, 3) on the first sides minus those of the second sides'
        (at distance along -away), each point fixed to its side's body (the world's does not move).

        With data.J's column e a twist (v_e, w_e) at the world origin, a point x fixed to the body
        the column moves has the velocity v_e + w_e x x, and a . (v_e + w_e x x) = [a, x x a] .
        (v_e, w_e): one product of the wrenches [a, x x a] (2 k, 6) with data.J gives every
        projection."""
        count = len(pairs)
        wrenches = self._wrenches[: 2 * count]
        wrenches[:count, :3] = aways
        np.negative(aways, out=wrenches[count:, :3])
        # the other sides' witness points, at distance along -away: x x (-a) = -(p x a) + d (a x a)
        # = -(p x a)
        np.subtract(
            points.take(_NEXT, axis=1) * aways.take(_AFTER_NEXT, axis=1),
            points.take(_AFTER_NEXT, axis=1) * aways.take(_NEXT, axis=1),
            out=wrenches[:count, 3:],
        )
        np.negative(wrenches[:count, 3:], out=wrenches[count:, 3:])
        along = wrenches @ self.robot.data.J  # (2 k, E)
        along *= self._side_supports.take(
            np.concatenate([pairs, pairs + len(self.pair_names)]), axis=0
        )
        return (along[:count] + along[count:]) @ self.robot.extended_to_q


#: Index permutations of (x, y, z) for row-wise cross products: a x b = a[NEXT] b[AFTER_NEXT] -
#: a[AFTER_NEXT] b[NEXT].
_NEXT, _AFTER_NEXT = np.array([1, 2, 0]), np.array([2, 0, 1])


def _geometry_reach(robot: RobotModel, objects, bounds) -> np.ndarray:
    """(geometries, n): for each robot geometry and q entry, how far a point of the geometry can
    move per radian of that entry at most, m/rad: the distance bound from each joint turned by the
    entry to the geometry's points (along the kinematic chain: the joints' offsets, the geometry's
    placement and its bounding radius), times the entry's multiplier (mimic joints follow their
    source)."""
    model = robot.model
    multipliers = {mimic.name: abs(mimic.multiplier) for mimic in robot.mimic_joints}
    columns = model.idx_vExtendeds
    reach = np.zeros((len(objects), robot.n_joints))
    for g, geometry in enumerate(objects):
        joint = geometry.parentJoint
        distance = np.linalg.norm(geometry.placement.translation) + bounds[g]
        while joint != 0:
            source = int(np.flatnonzero(robot.extended_to_q[columns[joint]])[0])
            reach[g, source] += multipliers.get(model.names[joint], 1.0) * distance
            distance += np.linalg.norm(model.jointPlacements[joint].translation)
            joint = model.parents[joint]
    return reach
