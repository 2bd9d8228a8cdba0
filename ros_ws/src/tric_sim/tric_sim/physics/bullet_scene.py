"""A situation's bodies built in a PyBullet client: the table, obstacles and grasp target as
primitive multibodies, and the box as a static body whose lid is a link on a hinge with friction;
and the robot's contact rules there. Units: m, rad, kg, N m."""

from tric_sim.physics.bullet import pb
from tric_sim.world import scene
from tric_sim.world.situation import Situation

COLORS = {
    "table": (0.82, 0.72, 0.55, 1.0),
    "target": (0.85, 0.15, 0.12, 1.0),
    "box_body": (0.55, 0.38, 0.2, 1.0),
    "lid": (0.75, 0.55, 0.3, 1.0),
    "obstacle": (0.45, 0.45, 0.5, 1.0),
}
#: Friction coefficients of the fingers and the objects.
LATERAL_FRICTION = 0.6
SPINNING_FRICTION = 0.002
#: The lid's hinge range, rad: closed (resting on the box) to flung open.
LID_RANGE = (0.0, 2.2)


def robot_contact_rules(client: int, uid: int, robot, link_index: dict) -> set:
    """Apply a robot's contact rules to its PyBullet body uid (link name -> index: link_index): its
    links' friction; returns the indices of the links mounted on the table (the base, -1, and its
    profile's mounted_links), which are not checked against the scene (and never collide with the
    table: PhysicsWorld.reset)."""
    for link in range(-1, pb.getNumJoints(uid, physicsClientId=client)):
        pb.changeDynamics(
            uid,
            link,
            lateralFriction=LATERAL_FRICTION,
            spinningFriction=SPINNING_FRICTION,
            physicsClientId=client,
        )
    mounted = robot.profile.mounted_links
    return {-1, *(link_index[link] for link in mounted if link in link_index)}


def create_body(client: int, body: scene.Body, situation: Situation) -> int:
    """The PyBullet body of one of the scene's bodies (for the box body: with its lid), its id."""
    color = COLORS[body.role]
    collision, visual = _shape(client, body.shape, body.dimensions, color)
    if body.role == "box_body":
        return _create_box_with_lid(client, body, situation, collision, visual)
    mass = scene.OBJECT_MASS[situation.object_kind] if body.role == "target" else 0.0
    uid = pb.createMultiBody(
        mass, collision, visual, body.position, body.orientation, physicsClientId=client
    )
    pb.changeDynamics(
        uid,
        -1,
        lateralFriction=LATERAL_FRICTION,
        spinningFriction=SPINNING_FRICTION,
        rollingFriction=0.0005,
        physicsClientId=client,
    )
    return uid


def _create_box_with_lid(client: int, body, situation, collision, visual) -> int:
    side = situation.object_dimensions[0]
    lid_collision, lid_visual = _shape(
        client,
        "box",
        scene.lid_extents(side),
        COLORS["lid"],
        offset=scene.lid_geometry_offset(side).translation,
    )
    hinge_local = pb.multiplyTransforms(
        *pb.invertTransform(body.position, body.orientation),
        *scene.pose_tuple(scene.hinge_placement(situation)),
    )
    lid_com = scene.lid_geometry_offset(side).translation
    uid = pb.createMultiBody(
        0.0,
        collision,
        visual,
        body.position,
        body.orientation,
        linkMasses=[scene.LID_MASS],
        linkCollisionShapeIndices=[lid_collision],
        linkVisualShapeIndices=[lid_visual],
        linkPositions=[hinge_local[0]],
        linkOrientations=[hinge_local[1]],
        linkInertialFramePositions=[lid_com.tolist()],
        linkInertialFrameOrientations=[[0, 0, 0, 1]],
        linkParentIndices=[0],
        linkJointTypes=[pb.JOINT_REVOLUTE],
        linkJointAxis=[[0, -1, 0]],
        physicsClientId=client,
    )
    pb.changeDynamics(
        uid,
        0,
        lateralFriction=LATERAL_FRICTION,
        jointLowerLimit=LID_RANGE[0],
        jointUpperLimit=LID_RANGE[1],
        physicsClientId=client,
    )
    pb.setJointMotorControl2(
        uid,
        0,
        pb.VELOCITY_CONTROL,
        targetVelocity=0.0,
        force=scene.LID_HINGE_FRICTION,
        physicsClientId=client,
    )
    # A multibody's links do not collide with their parent by default: the lid must rest on,
    # not sink into, the box.
    pb.setCollisionFilterPair(uid, uid, -1, 0, enableCollision=1, physicsClientId=client)
    return uid


def _shape(client: int, shape: str, dimensions, color, offset=(0.0, 0.0, 0.0)):
    kwargs = {"physicsClientId": client}
    if shape == "box":
        half = [d / 2 for d in dimensions]
        c = pb.createCollisionShape(
            pb.GEOM_BOX, halfExtents=half, collisionFramePosition=offset, **kwargs
        )
        v = pb.createVisualShape(
            pb.GEOM_BOX, halfExtents=half, rgbaColor=color, visualFramePosition=offset, **kwargs
        )
    elif shape == "sphere":
        c = pb.createCollisionShape(pb.GEOM_SPHERE, radius=dimensions[0], **kwargs)
        v = pb.createVisualShape(pb.GEOM_SPHERE, radius=dimensions[0], rgbaColor=color, **kwargs)
    else:
        height, radius = dimensions
        c = pb.createCollisionShape(pb.GEOM_CYLINDER, radius=radius, height=height, **kwargs)
        v = pb.createVisualShape(
            pb.GEOM_CYLINDER, radius=radius, length=height, rgbaColor=color, **kwargs
        )
    return c, v
