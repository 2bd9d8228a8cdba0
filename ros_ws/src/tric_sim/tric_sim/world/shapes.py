"""The solid primitives of scenes and of the robot's collision model, as geometry: coal shapes,
signed distances of points to a scene body or an object's surface (with its normals), bounding
spheres, and separating-axis tests vectorized over configurations (tric_sim.world.collision uses
them to check many configurations at once). Units: m.
"""

import math

import coal
import numpy as np
import pinocchio as pin

from tric_sim.world import scene


def coal_shape(shape: str, dimensions):
    """A coal primitive: box (full extents), sphere (radius,), cylinder (height, radius)."""
    if shape == "box":
        return coal.Box(*dimensions)
    if shape == "sphere":
        return coal.Sphere(dimensions[0])
    height, radius = dimensions
    return coal.Cylinder(radius, height)


def bounding_radius(shape: str, dimensions) -> float:
    """The radius of the smallest sphere about a primitive's origin that holds it, m."""
    if shape == "box":
        return 0.5 * math.sqrt(sum(d * d for d in dimensions))
    if shape == "sphere":
        return dimensions[0]
    height, radius = dimensions
    return math.hypot(height / 2, radius)


def bounding_spheres(geometry) -> list:
    """Spheres (centre in the geometry's frame (3,), radius) that together cover a coal Cylinder or
    Sphere (or, for anything else, one sphere around its local AABB)."""
    shape = geometry
    if isinstance(shape, coal.Sphere):
        return [(np.zeros(3), shape.radius)]
    if isinstance(shape, coal.Cylinder):
        length = 2 * shape.halfLength
        count = max(1, math.ceil(length / (2 * shape.radius)))
        half_piece = length / count / 2
        radius = math.hypot(shape.radius, half_piece)
        return [
            (np.array([0.0, 0.0, -length / 2 + half_piece * (2 * k + 1)]), radius)
            for k in range(count)
        ]
    shape.computeLocalAABB()
    box = shape.aabb_local
    centre = (np.array(box.min_) + np.array(box.max_)) / 2
    return [(centre, float(np.linalg.norm(np.array(box.max_) - centre)))]


def exact_distances(
    shape, rotations, positions, local: pin.SE3, body: scene.Body, placement: pin.SE3
):
    """Exact signed distances (B,) between a robot geometry (a coal shape on a joint at rotations
    (B, 3, 3) and positions (B, 3), placed at local in the joint's frame) and a scene body at
    placement, where a closed form exists: a robot sphere against any body, a robot cylinder against
    a spherical body (the distance to the other's surface); None otherwise."""
    centres = positions + rotations @ local.translation
    if isinstance(shape, coal.Sphere):
        return body_distance(body, placement, centres) - shape.radius
    if isinstance(shape, coal.Cylinder) and body.shape == "sphere":
        # the sphere's centre in each cylinder's frame, against the cylinder's surface
        axes = rotations @ local.rotation
        relative = np.einsum("bji,bj->bi", axes, placement.translation - centres)
        cylinder = pin.SE3.Identity()
        distance, _ = object_surface(
            "cylinder", (2 * shape.halfLength, shape.radius), cylinder, relative
        )
        return distance - body.dimensions[0]
    return None


def body_distance(body: scene.Body, placement: pin.SE3, points: np.ndarray) -> np.ndarray:
    """Signed distance (k,) of points (k, 3) to a scene body's surface, the body's solid at
    placement."""
    if body.shape == "sphere":
        offsets = points - placement.translation
        return np.sqrt(np.einsum("ka,ka->k", offsets, offsets)) - body.dimensions[0]
    if body.shape == "cylinder":
        return object_surface(body.shape, body.dimensions, placement, points)[0]
    local = (points - placement.translation) @ placement.rotation
    q = np.abs(local) - np.asarray(body.dimensions) / 2
    outside = np.maximum(q, 0.0)
    return np.sqrt(np.einsum("ka,ka->k", outside, outside)) + np.minimum(q.max(axis=1), 0.0)


class Cylinder:
    """Cylinders for separating-axis tests, vectorized over configurations: centres (B, 3), unit
    axes (B, 3), half lengths and radii (scalars)."""

    def __init__(self, centres, axes, half_length, radius):
        self.centres, self.axes, self.half_length, self.radius = centres, axes, half_length, radius

    @classmethod
    def of(cls, shape, joint_rotations, joint_positions, local: pin.SE3) -> "Cylinder":
        centres = joint_positions + joint_rotations @ local.translation
        axes = joint_rotations @ local.rotation[:, 2]
        return cls(centres, axes, shape.halfLength, shape.radius)

    def half_extent(self, directions: np.ndarray) -> np.ndarray:
        """Half the length of the cylinders' projections on unit directions (B, 3)."""
        along = np.abs(np.einsum("bi,bi->b", self.axes, directions))
        return along * self.half_length + self.radius * np.sqrt(np.maximum(1.0 - along**2, 0.0))

    def separated_from(self, other) -> np.ndarray:
        """(B,) True where a separating axis proves the two solids apart: the cylinders' axes and,
        for a box, its face normals."""
        axes = [self.axes] + other.axes_to_test()
        if isinstance(other, Cylinder):
            axes.append(other.axes)
        offset = other.centres - self.centres
        apart = np.zeros(len(offset), dtype=bool)
        for direction in axes:
            gap = np.abs(np.einsum("bi,bi->b", offset, direction))
            apart |= gap > self.half_extent(direction) + other.half_extent(direction)
        return apart

    def axes_to_test(self) -> list:
        return []


class Box:
    """An oriented box repeated for B configurations (the scene's bodies do not move with q)."""

    def __init__(self, placement: pin.SE3, extents, count: int):
        self.centres = np.broadcast_to(placement.translation, (count, 3))
        self.normals = [np.broadcast_to(placement.rotation[:, k], (count, 3)) for k in range(3)]
        self.half = np.asarray(extents) / 2

    def half_extent(self, directions: np.ndarray) -> np.ndarray:
        return sum(
            np.abs(np.einsum("bi,bi->b", n, directions)) * h
            for n, h in zip(self.normals, self.half)
        )

    def axes_to_test(self) -> list:
        return list(self.normals)


def body_solid(body: scene.Body, placement: pin.SE3, count: int):
    """A scene body as a solid for separating-axis tests, repeated count times (spherical bodies
    are handled exactly by exact_distances)."""
    if body.shape == "box":
        return Box(placement, body.dimensions, count)
    height, radius = body.dimensions
    return Cylinder(
        np.broadcast_to(placement.translation, (count, 3)),
        np.broadcast_to(placement.rotation[:, 2], (count, 3)),
        height / 2,
        radius,
    )


def object_surface(kind: str, dimensions, placement: pin.SE3, points: np.ndarray):
    """Signed distance (m) of points (k, 3) to a sphere's or a finite cylinder's surface, and the
    outward unit normals (k, 3) at their nearest surface points."""
    local = (points - placement.translation) @ placement.rotation
    if kind == "sphere":
        norm = np.linalg.norm(local, axis=1)
        normals = local / np.maximum(norm, 1e-12)[:, None]
        return norm - dimensions[0], normals @ placement.rotation.T
    height, radius = dimensions
    radial = local.copy()
    radial[:, 2] = 0.0
    rho = np.linalg.norm(radial, axis=1)
    d_radial, d_axial = rho - radius, np.abs(local[:, 2]) - height / 2
    outside = np.hypot(np.maximum(d_radial, 0), np.maximum(d_axial, 0))
    inside = np.minimum(np.maximum(d_radial, d_axial), 0)
    radial_dir = radial / np.maximum(rho, 1e-12)[:, None]
    axial_dir = np.zeros_like(local)
    axial_dir[:, 2] = np.sign(local[:, 2])
    normals = np.where((d_radial >= d_axial)[:, None], radial_dir, axial_dir)
    return outside + inside, normals @ placement.rotation.T
