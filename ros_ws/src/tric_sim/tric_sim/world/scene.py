"""The bodies a situation consists of, as one geometric description for PyBullet and for coal.

Every body is a solid primitive at a world pose. The box's lid is the one articulated body: its
frame sits on the hinge axis (x from the hinge towards the free edge, z along the lid's normal,
opening = positive rotation about -y), and its plate is offset from that frame by
LID_GEOMETRY_OFFSET. Units: m, rad; quaternions xyzw.
"""

from dataclasses import dataclass

import numpy as np
import pinocchio as pin

from tric_sim.world.robot_profile import RobotProfile
from tric_sim.world.situation import Situation

#: The table top is the plane z = 0 under the robot and the objects.
TABLE_SIZE = (1.6, 1.6, 0.05)
TABLE_POSITION = (0.4, 0.0, -0.025)

#: Lid: a plate LID_THICKNESS thick, overhanging the box's front wall by LID_OVERHANG (the lip a
#: finger reaches under) and its side walls by LID_SIDE_MARGIN each; it rests LID_GAP above the
#: body.
LID_THICKNESS = 0.012
LID_OVERHANG = 0.05
LID_SIDE_MARGIN = 0.005
LID_GAP = 0.001
LID_MASS = 0.25
#: Hinge friction torque, N m (applied by the simulator as a velocity motor with this force).
LID_HINGE_FRICTION = 0.05

#: Masses of the grasp targets, kg.
OBJECT_MASS = {"sphere": 0.1, "cylinder": 0.3}

#: Body roles: "table", "obstacle" and "box_body" are avoided by every controller; "target" (the
#: grasp object) and "lid" may be touched by the hand (TASK_CONTACTS says how).
AVOIDED_ROLES = ("table", "obstacle", "box_body")


@dataclass(frozen=True)
class Contact:
    """A task's leave for the hand to touch a scene body.

    depth: how far the hand may press into the body, m (the collision damper's safety distance is
        -depth for the hand's pairs with it).
    side: a unit direction (3,) in the body's frame: the leave holds only while the hand is on that
        side of the body (the direction from the body to the hand points along it), e.g. (0, 0, -1):
        from beneath; elsewhere the body is kept clear of like any other. None: from every side.
    cushion, cushion_weight: within cushion (m) of the surface the hand is pushed back softly, as by
        a spring of stiffness cushion_weight (relative to the controller's step-size term) along the
        distance's gradient; cushion 0: no such prior.
    """

    depth: float
    side: tuple | None = None
    cushion: float = 0.0
    cushion_weight: float = 0.0


#: Each task's contacts, by the role of the body they are for: the fingers may press a few
#: millimetres into the grasp target, within a soft cushion that keeps them from jamming; the hand
#: may press the lid deeper, from beneath only, with no cushion (docs/decisions/contact-rules.md).
TASK_CONTACTS = {
    "grasp": {"target": Contact(depth=0.005, cushion=0.003, cushion_weight=3.0)},
    "open_box": {"lid": Contact(depth=0.015, side=(0.0, 0.0, -1.0))},
}


@dataclass(frozen=True)
class Grip:
    """A task's last phase, once the controller has come to rest: joints closed by squeeze (rad)
    past where they rest, ramped in over duration_s (s), then held; within their limits."""

    joints: tuple
    squeeze: float
    duration_s: float


def task_grip(task: str, profile: RobotProfile) -> Grip | None:
    """A task's grip (None: none): a grasp closes the fingers' flexion joints by the robot
    profile's squeeze (the grasp teacher's squeeze past contact) past where they came to rest, so
    that the fingers hold the object with force, not only friction
    (docs/decisions/rest-and-grip.md); a box keeps the hand where it came to rest, the lid held."""
    if task not in TASK_CONTACTS:
        raise ValueError(f"no grip for task '{task}' (known: {', '.join(TASK_CONTACTS)})")
    if task != "grasp":
        return None
    return Grip(profile.flexion_joints, profile.grip_squeeze, profile.grip_duration_s)


@dataclass(frozen=True)
class Body:
    """One solid primitive of the scene.

    shape "box": dimensions = full extents (x, y, z); "sphere": (radius,); "cylinder": (height,
    radius) with the axis along local z. position (3,) and orientation (xyzw) are the world pose of
    the body's frame; for the lid that frame is the hinge frame at lid angle 0 and the plate is
    offset from it by LID_GEOMETRY_OFFSET.
    """

    name: str
    role: str
    shape: str
    dimensions: tuple
    position: tuple
    orientation: tuple
    #: (position, xyzw) of the solid in the body's frame (the lid's plate in its hinge frame); None:
    #: the solid is centred on the frame.
    geometry_offset: tuple | None = None

    def solid_placement(self, pose=None) -> pin.SE3:
        """World placement of the body's solid with its frame at pose (position, xyzw), default the
        body's own."""
        placement = se3(*(pose if pose is not None else (self.position, self.orientation)))
        return placement if self.geometry_offset is None else placement * se3(*self.geometry_offset)


def se3(position, orientation) -> pin.SE3:
    """Pinocchio placement from a position (3,) and an xyzw quaternion."""
    x, y, z, w = orientation
    return pin.SE3(pin.Quaternion(w, x, y, z).normalized().matrix(), np.asarray(position, float))


def pose_tuple(placement: pin.SE3) -> tuple:
    """(position, xyzw quaternion) of a placement, as tuples of floats."""
    q = pin.Quaternion(placement.rotation)
    return (
        tuple(float(v) for v in placement.translation),
        (float(q.x), float(q.y), float(q.z), float(q.w)),
    )


def lid_extents(side: float) -> tuple:
    """Full extents (depth along the lid frame's x, width, thickness) of a box's lid plate."""
    return (side + LID_OVERHANG, side + 2 * LID_SIDE_MARGIN, LID_THICKNESS)


def lid_geometry_offset(side: float) -> pin.SE3:
    """Placement of the lid plate's centre in the lid (hinge) frame."""
    depth, _, thickness = lid_extents(side)
    return pin.SE3(np.eye(3), np.array([depth / 2, 0.0, thickness / 2]))


def lid_edge_offset(side: float) -> pin.SE3:
    """Placement of the lid's lip (the middle of its free edge, on its underside) in the lid (hinge)
    frame: where a finger lifts the lid from."""
    return pin.SE3(np.eye(3), np.array([lid_extents(side)[0], 0.0, 0.0]))


def hinge_placement(situation: Situation) -> pin.SE3:
    """World placement of the closed lid's hinge frame: on the body's top edge at local +x, x
    pointing back over the box (towards local -x), z up."""
    side = situation.object_dimensions[0]
    body = se3(situation.object_position, situation.object_orientation)
    local = pin.SE3(pin.utils.rotate("z", np.pi), np.array([side / 2, 0.0, side / 2 + LID_GAP]))
    return body * local


def lid_placement(hinge: pin.SE3, angle: float) -> pin.SE3:
    """World placement of the lid frame opened by angle (rad) about its hinge."""
    return hinge * pin.SE3(pin.utils.rotate("y", -angle), np.zeros(3))


def scene_bodies(situation: Situation) -> list:
    """The bodies of a situation's scene: the table, the object (and the lid), the obstacles."""
    bodies = [Body("table", "table", "box", TABLE_SIZE, TABLE_POSITION, (0.0, 0.0, 0.0, 1.0))]
    if situation.object_kind == "box":
        side = situation.object_dimensions[0]
        bodies.append(
            Body(
                "object",
                "box_body",
                "box",
                (side, side, side),
                situation.object_position,
                situation.object_orientation,
            )
        )
        position, orientation = pose_tuple(hinge_placement(situation))
        bodies.append(
            Body(
                "lid",
                "lid",
                "box",
                lid_extents(side),
                position,
                orientation,
                pose_tuple(lid_geometry_offset(side)),
            )
        )
    else:
        bodies.append(
            Body(
                "object",
                "target",
                situation.object_kind,
                situation.object_dimensions,
                situation.object_position,
                situation.object_orientation,
            )
        )
    for k, obstacle in enumerate(situation.obstacles):
        bodies.append(
            Body(
                f"obstacle_{k}",
                "obstacle",
                obstacle.shape,
                obstacle.dimensions,
                obstacle.position,
                obstacle.orientation,
            )
        )
    return bodies


def contacts(situation: Situation) -> dict:
    """The contacts the situation's task allows the hand, by scene body name (see TASK_CONTACTS)."""
    allowed = TASK_CONTACTS[situation.task]
    return {
        body.name: allowed[body.role] for body in scene_bodies(situation) if body.role in allowed
    }
