"""What a viewer draws: the robot's links and the scene's bodies as solid primitives in named
frames, and the transforms between those frames. ROS-free and message-free:
tric_sim.viz.scene_messages makes RViz's messages of it (MarkerArray, tf) and
tric_sim.viz.foxglove_view Foxglove's.

Frames (one tree, rooted at "world"):
- every URDF link, with one transform per URDF joint from its parent link to its child link (the
  names and the convention of robot_state_publisher); "world" -> the robot profile's base is the
  identity (the simulator fixes the robot's base at the origin);
- "world" -> each name of /object_poses: "object", "lid" (the hinge frame), "lid_edge",
  "obstacle_0", ...

Primitives:
- group "robot": one per <collision> element of the URDF (the geometry the collision model and
  PyBullet use), in its link's frame, coloured as the link's visual material;
- group "scene": the bodies of tric_sim.world.scene.scene_bodies, the geometry the simulator
  builds: the table in "world", every other body in the frame of its name (the lid's plate offset
  from its hinge frame by scene.lid_geometry_offset).
A primitive's size is its full extent along its own axes: box (x, y, z), sphere (d, d, d), cylinder
(d, d, height) with the axis along z: the scale convention of visualization_msgs/Marker and of
Foxglove's primitives. Units: m, rad; quaternions xyzw.
"""

import pathlib
import xml.etree.ElementTree as ET
from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from tric_sim.world import scene
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.situation import Situation

WORLD = "world"
IDENTITY = (0.0, 0.0, 0.0, 1.0)

#: Colours (rgba) of the scene's bodies by role.
ROLE_COLORS = {
    "table": (0.55, 0.45, 0.35, 1.0),
    "target": (0.9, 0.3, 0.1, 1.0),
    "box_body": (0.8, 0.65, 0.4, 1.0),
    "lid": (0.6, 0.45, 0.25, 1.0),
    "obstacle": (0.8, 0.1, 0.1, 0.6),
}
LINK_COLOR = (0.6, 0.6, 0.65, 1.0)


@dataclass(frozen=True)
class Primitive:
    """One solid primitive to draw: a box, sphere or cylinder of full extents size (3,) at a pose
    (position (3,), orientation xyzw) in frame; id is unique, group "robot" or "scene"."""

    id: str
    group: str
    frame: str
    shape: str
    size: tuple
    position: tuple
    orientation: tuple
    color: tuple


@dataclass(frozen=True)
class Transforms:
    """Transforms from parents[i] to children[i]: the child frame's origin positions (k, 3) and
    orientations (k, 4, xyzw) in its parent frame."""

    parents: tuple
    children: tuple
    positions: np.ndarray
    orientations: np.ndarray

    def __len__(self) -> int:
        return len(self.children)


@dataclass(frozen=True)
class _Joint:
    name: str
    kind: str
    parent: str
    child: str
    position: tuple
    orientation: tuple
    axis: np.ndarray


class RobotView:
    """The robot as a viewer sees it, from its URDF: the links' collision primitives, the fixed
    joints' transforms and, for a configuration q, the moving joints' transforms."""

    def __init__(self, robot: RobotModel):
        self.robot = robot
        root = ET.parse(robot.urdf_path).getroot()
        self.urdf = pathlib.Path(robot.urdf_path).read_text()
        joints = [_parse_joint(tag) for tag in root.iter("joint")]
        fixed = [j for j in joints if j.kind == "fixed"]
        moving = [j for j in joints if j.kind != "fixed"]
        if any(j.kind not in ("revolute", "continuous", "prismatic") for j in moving):
            raise ValueError("the viewer draws fixed, revolute, continuous and prismatic joints")
        self.static = Transforms(
            (WORLD,) + tuple(j.parent for j in fixed),
            (robot.profile.base,) + tuple(j.child for j in fixed),
            np.array([(0.0, 0.0, 0.0)] + [j.position for j in fixed]),
            np.array([IDENTITY] + [j.orientation for j in fixed]),
        )
        self._parents = tuple(j.parent for j in moving)
        self._children = tuple(j.child for j in moving)
        self._origins = np.array([j.position for j in moving])
        self._origin_rotations = np.array([j.orientation for j in moving])
        self._axes = np.array([j.axis for j in moving])
        self._sliding = np.array([j.kind == "prismatic" for j in moving])
        # each moving joint's angle = multiplier * q[source] + offset (mimic joints follow their
        # source)
        mimics = {m.name: m for m in robot.mimic_joints}
        self._sources = np.array(
            [
                robot.joint_names.index(mimics[j.name].source if j.name in mimics else j.name)
                for j in moving
            ]
        )
        self._multipliers = np.array(
            [mimics[j.name].multiplier if j.name in mimics else 1.0 for j in moving]
        )
        self._offsets = np.array(
            [mimics[j.name].offset if j.name in mimics else 0.0 for j in moving]
        )
        self.primitives = _link_primitives(root)

    def transforms(self, q) -> Transforms:
        """The moving joints' transforms (parent link -> child link) at joint positions q (n,),
        rad (m for a prismatic joint: it slides along its axis instead of turning)."""
        values = self._multipliers * np.asarray(q, dtype=float)[self._sources] + self._offsets
        half = np.where(self._sliding, 0.0, 0.5 * values)
        turns = np.concatenate([self._axes * np.sin(half)[:, None], np.cos(half)[:, None]], axis=1)
        rotations = quaternion_product(self._origin_rotations, turns)
        slides = np.where(self._sliding, values, 0.0)[:, None] * self._axes
        positions = self._origins + _rotate(self._origin_rotations, slides)
        return Transforms(self._parents, self._children, positions, rotations)


def object_transforms(poses: dict) -> Transforms:
    """ "world" -> each object's frame, from /object_poses' {name: (position, xyzw)}."""
    names = tuple(poses)
    return Transforms(
        (WORLD,) * len(names),
        names,
        np.array([poses[n][0] for n in names], dtype=float).reshape(-1, 3),
        np.array([poses[n][1] for n in names], dtype=float).reshape(-1, 4),
    )


def initial_object_poses(situation: Situation) -> dict:
    """The objects' poses at the start of a situation, {name: (position, xyzw)}, as /object_poses
    names them (the table, which is static, is not one)."""
    return {
        body.name: (tuple(body.position), tuple(body.orientation))
        for body in scene.scene_bodies(situation)
        if body.role != "table"
    }


def scene_primitives(situation: Situation) -> list:
    """The scene's bodies (table, object, lid, obstacles) as primitives; see the module
    docstring."""
    primitives = []
    for body in scene.scene_bodies(situation):
        position, orientation = (0.0, 0.0, 0.0), IDENTITY
        if body.role == "table":
            frame, position, orientation = WORLD, tuple(body.position), tuple(body.orientation)
        elif body.role == "lid":
            frame = body.name
            position, orientation = scene.pose_tuple(
                scene.lid_geometry_offset(situation.object_dimensions[0])
            )
        else:
            frame = body.name
        primitives.append(
            Primitive(
                f"scene/{body.name}",
                "scene",
                frame,
                body.shape,
                _extents(body.shape, body.dimensions),
                position,
                orientation,
                ROLE_COLORS[body.role],
            )
        )
    return primitives


def frame_placements(*transform_sets: Transforms) -> dict:
    """World placements {frame: pin.SE3} of every frame reachable from "world" through the given
    transforms (a tree: each frame has one parent)."""
    parent_of = {}
    for transforms in transform_sets:
        for k, child in enumerate(transforms.children):
            parent_of[child] = (
                transforms.parents[k],
                scene.se3(transforms.positions[k], transforms.orientations[k]),
            )
    placements = {WORLD: pin.SE3.Identity()}

    def resolve(frame):
        if frame not in placements:
            if frame not in parent_of:
                return None
            parent, local = parent_of[frame]
            above = resolve(parent)
            if above is None:
                return None
            placements[frame] = above * local
        return placements[frame]

    for frame in parent_of:
        resolve(frame)
    return placements


def quaternion_product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton products a b of xyzw quaternions (k, 4) (the rotation b, then a)."""
    ax, ay, az, aw = a.T
    bx, by, bz, bw = b.T
    return np.stack(
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ],
        axis=1,
    )


def _rotate(quaternions: np.ndarray, vectors: np.ndarray) -> np.ndarray:
    """Vectors (k, 3) turned by xyzw quaternions (k, 4): v + 2 w (u x v) + 2 u x (u x v)."""
    axes, w = quaternions[:, :3], quaternions[:, 3:]
    twice = 2.0 * np.cross(axes, vectors)
    return vectors + w * twice + np.cross(axes, twice)


def _extents(shape: str, dimensions) -> tuple:
    """Full extents (3,) of a primitive from scene dimensions: box (x, y, z), sphere (r,), cylinder
    (height, r)."""
    if shape == "box":
        return tuple(float(v) for v in dimensions)
    if shape == "sphere":
        return (2.0 * dimensions[0],) * 3
    if shape == "cylinder":
        return (2.0 * dimensions[1], 2.0 * dimensions[1], float(dimensions[0]))
    raise ValueError(f"unknown primitive shape '{shape}'")


def _origin(tag) -> tuple:
    """(position, xyzw) of a URDF <origin> element (None: the identity)."""
    if tag is None:
        return (0.0, 0.0, 0.0), IDENTITY
    xyz = [float(v) for v in tag.get("xyz", "0 0 0").split()]
    rpy = [float(v) for v in tag.get("rpy", "0 0 0").split()]
    return scene.pose_tuple(pin.SE3(pin.rpy.rpyToMatrix(*rpy), np.array(xyz)))


def _parse_joint(tag) -> _Joint:
    position, orientation = _origin(tag.find("origin"))
    axis_tag = tag.find("axis")
    axis = (
        np.array([float(v) for v in axis_tag.get("xyz").split()])
        if axis_tag is not None
        else np.array([1.0, 0, 0])
    )
    return _Joint(
        tag.get("name"),
        tag.get("type"),
        tag.find("parent").get("link"),
        tag.find("child").get("link"),
        position,
        orientation,
        axis / np.linalg.norm(axis),
    )


def _link_primitives(root) -> list:
    """One primitive per <collision> element of every link, coloured as the link's visual
    material."""
    materials = {
        m.get("name"): tuple(float(v) for v in m.find("color").get("rgba").split())
        for m in root.findall("material")
        if m.find("color") is not None
    }
    primitives = []
    for link in root.iter("link"):
        material = link.find("visual/material")
        color = (
            materials.get(material.get("name"), LINK_COLOR) if material is not None else LINK_COLOR
        )
        for k, collision in enumerate(link.findall("collision")):
            geometry = collision.find("geometry")[0]
            if geometry.tag == "box":
                shape, dimensions = "box", [float(v) for v in geometry.get("size").split()]
            elif geometry.tag == "sphere":
                shape, dimensions = "sphere", [float(geometry.get("radius"))]
            elif geometry.tag == "cylinder":
                shape, dimensions = (
                    "cylinder",
                    [float(geometry.get("length")), float(geometry.get("radius"))],
                )
            else:
                raise ValueError(
                    f"link {link.get('name')}: the viewer draws boxes, spheres and cylinders, "
                    f"not {geometry.tag}"
                )
            position, orientation = _origin(collision.find("origin"))
            primitives.append(
                Primitive(
                    f"robot/{link.get('name')}/{k}",
                    "robot",
                    link.get("name"),
                    shape,
                    _extents(shape, dimensions),
                    position,
                    orientation,
                    color,
                )
            )
    return primitives
