"""Collision checking of many configurations against a situation's scene, with coal: the noisy
samples of TRIC's training.

The robot's collision geometry is the URDF's (the Pinocchio GeometryModel of RobotModel); the
scene's is tric_sim.world.scene's bodies as coal primitives (tric_sim.world.shapes). SceneCollision
checks many configurations at once, vectorized: each robot geometry is covered by a few bounding
spheres, whose distances to the scene bodies and to each other are computed for all configurations
in numpy; coal then computes the exact distance only for the (configuration, geometry pair)
combinations whose bounding spheres come close. The controller's queries, one configuration at a
time, are tric_sim.world.proximity's.
Units: m, rad.
"""

import coal
import numpy as np

from tric_sim.world import scene, shapes
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation import Situation

#: Penetration allowed into the bodies the task lets the hand contact (scene.contacts) by default,
#: m: the fingers of a firm grip press a few millimetres into them in simulation.
CONTACT_TOLERANCE = 0.005


class SceneCollision:
    """The robot and one situation's scene.

    collision_free(configurations, object_poses) tells, for each configuration, whether the robot
    (but its base, which is mounted on the table) is clear of the scene's bodies, penetrating those
    that the task lets the hand contact (scene.contacts) by no more than contact_tolerance (m), and
    does not collide with itself (non-adjacent links).
    """

    def __init__(
        self, robot: RobotModel, situation: Situation, contact_tolerance: float = CONTACT_TOLERANCE
    ):
        self.robot = robot
        self.bodies = scene.scene_bodies(situation)
        self.situation = situation
        #: the contacts the task allows the hand: scene body name -> tric_sim.world.scene.Contact
        self.contacts = scene.contacts(situation)
        geometry_model = robot.collision_model
        self.robot_geometries = [
            (g.parentJoint, g.placement, g.geometry) for g in geometry_model.geometryObjects
        ]
        # geometry mounted on the table (the base, and the robot profile's mounted links) is not
        # checked against the scene
        self._moving = ~robot.mounted_geometries
        self.self_pairs = [(p.first, p.second) for p in geometry_model.collisionPairs]
        self.body_shapes = [shapes.coal_shape(b.shape, b.dimensions) for b in self.bodies]
        self.allowance = [
            contact_tolerance if b.name in self.contacts else 0.0 for b in self.bodies
        ]
        # bounding spheres: (geometry index, centre in the joint frame, radius)
        self.spheres = []
        for k, (_, placement, shape) in enumerate(self.robot_geometries):
            for centre, radius in shapes.bounding_spheres(shape):
                self.spheres.append((k, placement.act(centre), radius))
        self._sphere_geometry = np.array([s[0] for s in self.spheres])
        self._sphere_radius = np.array([s[2] for s in self.spheres])
        # every pair of bounding spheres of every self-collision pair: (first, second, pair index)
        combos = [
            (i, j, k)
            for k, (a, c) in enumerate(self.self_pairs)
            for i in np.flatnonzero(self._sphere_geometry == a)
            for j in np.flatnonzero(self._sphere_geometry == c)
        ]
        self._combo_first, self._combo_second, self._combo_pair = (
            np.array(v) for v in zip(*combos)
        )
        self._combo_reach = (
            self._sphere_radius[self._combo_first] + self._sphere_radius[self._combo_second]
        )
        self._pair_starts = np.flatnonzero(np.r_[True, np.diff(self._combo_pair) != 0])
        self._functors: dict[tuple[int, int], coal.ComputeDistance] = {}
        self._request = coal.DistanceRequest()
        self._result = coal.DistanceResult()

    def body_placements(self, object_poses: dict, bodies=None) -> list:
        """World placement of each scene body's solid (of bodies, default all); bodies named in
        object_poses (name -> (position, xyzw)) are placed there."""
        return [
            body.solid_placement(object_poses.get(body.name))
            for body in (self.bodies if bodies is None else bodies)
        ]

    def collision_free(self, configurations: np.ndarray, object_poses: dict) -> np.ndarray:
        """Boolean mask (B,) over configurations (B, n)."""
        qs = np.asarray(configurations, dtype=float).reshape(-1, self.robot.n_joints)
        if len(qs) == 0:
            return np.zeros(0, dtype=bool)
        rotations, positions = self.robot.batch_joint_placements(qs)
        joints = [self.robot_geometries[k][0] for k, _, _ in self.spheres]
        centres = np.stack(
            [positions[j] + rotations[j] @ c for j, (_, c, _) in zip(joints, self.spheres)], 1
        )
        placements = self.body_placements(object_poses)
        free = np.ones(len(qs), dtype=bool)
        # (configuration, robot geometry, body index or None, other robot geometry or None)
        suspects: list[tuple] = []
        for b, (body, placement) in enumerate(zip(self.bodies, placements)):
            for geometry, (joint, local, shape) in enumerate(self.robot_geometries):
                if not self._moving[geometry]:
                    continue
                exact = shapes.exact_distances(
                    shape, rotations[joint], positions[joint], local, body, placement
                )
                if exact is not None:
                    free &= exact >= -self.allowance[b]
                    continue
                spheres = np.flatnonzero(self._sphere_geometry == geometry)
                clearance = shapes.body_distance(
                    body, placement, centres[:, spheres].reshape(-1, 3)
                )
                near = np.flatnonzero(
                    (clearance.reshape(len(qs), -1) - self._sphere_radius[spheres] < 1e-3).any(
                        axis=1
                    )
                    & free
                )
                if len(near) and isinstance(shape, coal.Cylinder):
                    solid = shapes.Cylinder.of(
                        shape, rotations[joint][near], positions[joint][near], local
                    )
                    near = near[
                        ~solid.separated_from(shapes.body_solid(body, placement, len(near)))
                    ]
                suspects += [(config, geometry, b, None) for config in near]
        by_sphere = np.ascontiguousarray(centres.transpose(1, 2, 0))  # (spheres, 3, B)
        offsets = by_sphere[self._combo_first] - by_sphere[self._combo_second]  # (combos, 3, B)
        squared = offsets[:, 0] ** 2 + offsets[:, 1] ** 2 + offsets[:, 2] ** 2
        close = squared < ((self._combo_reach + 1e-3) ** 2)[:, None]  # (combos, B)
        close_pairs = np.maximum.reduceat(close, self._pair_starts, axis=0).T  # (B, self pairs)
        for pair in np.flatnonzero(close_pairs.any(axis=0)):
            a, c = self.self_pairs[self._combo_pair[self._pair_starts[pair]]]
            near = np.flatnonzero(close_pairs[:, pair] & free)
            (ja, la, sa), (jc, lc, sc) = self.robot_geometries[a], self.robot_geometries[c]
            if len(near) and isinstance(sa, coal.Cylinder) and isinstance(sc, coal.Cylinder):
                first = shapes.Cylinder.of(sa, rotations[ja][near], positions[ja][near], la)
                second = shapes.Cylinder.of(sc, rotations[jc][near], positions[jc][near], lc)
                near = near[~first.separated_from(second)]
            suspects += [(config, a, None, c) for config in near]
        for config, geometry, body, other in suspects:
            if not free[config]:
                continue
            if body is not None:
                other_shape, other_rotation, other_translation = (
                    self.body_shapes[body],
                    placements[body].rotation,
                    placements[body].translation,
                )
                allowance = self.allowance[body]
            else:
                other_shape, other_rotation, other_translation = self._world(
                    other, rotations, positions, config
                )
                allowance = 0.0
            shape = self.robot_geometries[geometry][2]
            rotation, translation = self._world(geometry, rotations, positions, config)[1:]
            key = (id(shape), id(other_shape))
            functor = self._functors.get(key)
            if functor is None:
                functor = self._functors[key] = coal.ComputeDistance(shape, other_shape)
            self._result.clear()
            distance = functor(
                coal.Transform3s(rotation, translation),
                coal.Transform3s(other_rotation, other_translation),
                self._request,
                self._result,
            )
            free[config] = distance >= -allowance
        return free

    def _world(self, geometry, rotations, positions, config):
        """(shape, world rotation, world translation) of a robot geometry in one configuration."""
        joint, local, shape = self.robot_geometries[geometry]
        rotation = rotations[joint][config]
        return (
            shape,
            rotation @ local.rotation,
            positions[joint][config] + rotation @ local.translation,
        )
