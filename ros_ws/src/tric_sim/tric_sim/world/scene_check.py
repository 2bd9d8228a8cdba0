"""Whether a situation can physically be: the robot in its initial configuration within its joint
limits, clear of the table
(its links but the base, mounted on it, reaching into it by no more than TABLE_TOLERANCE) and of
itself (the self-collision pairs of RobotModel), its object (or the box's lid) not reaching into the
table by more than TABLE_TOLERANCE, and its object, lid and obstacles clear of the robot, measured
with coal on the robot's collision model; and a grasp target its perturbations move
(tric_sim.world.perturbations) still clear of the table where they leave it."""

import numpy as np

from tric_sim.world.situation import Situation

#: How deep the object may reach into the table top, m (a box stands on it, touching it exactly).
TABLE_TOLERANCE = 1e-3


def check_scene(situation: Situation, robot) -> Situation:
    """situation, or ValueError naming the pair if it cannot physically be, in the robot's initial
    configuration (initial_joint_positions, else the robot's home): a joint outside its limits, a
    robot link (not the base)
    reaching into the table by more than TABLE_TOLERANCE, two robot links of a self-collision pair
    intersecting, its object (or the box's lid) reaching into the table by more than
    TABLE_TOLERANCE, or its object, lid or an obstacle intersecting the robot (any link, its base
    too). robot: a tric_sim.world.robot_model.RobotModel."""
    # imported here: Pinocchio and coal only once a scene is checked
    import coal
    import pinocchio as pin

    from tric_sim.world.perturbations import target_displacement
    from tric_sim.world.scene import lid_geometry_offset, scene_bodies, se3
    from tric_sim.world.shapes import coal_shape

    where = f"situation '{situation.name}'"
    q = robot.check_configuration(
        situation.initial_joint_positions or robot.home, f"{where}: initial_joint_positions"
    )
    data, geometry_data = robot.model.createData(), pin.GeometryData(robot.collision_model)
    pin.updateGeometryPlacements(robot.model, data, robot.collision_model, geometry_data, q)
    robot_parts = [
        (robot.model.frames[g.parentFrame].name, g.geometry, placement)
        for g, placement in zip(robot.collision_model.geometryObjects, geometry_data.oMg)
    ]
    moving = ~robot.mounted_geometries
    table, *bodies = scene_bodies(situation)
    table_shape, table_placement = (
        coal_shape(table.shape, table.dimensions),
        se3(table.position, table.orientation),
    )

    def distance(shape, placement, other_shape, other_placement) -> float:
        return coal.distance(
            shape,
            coal.Transform3s(placement.rotation, placement.translation),
            other_shape,
            coal.Transform3s(other_placement.rotation, other_placement.translation),
            coal.DistanceRequest(),
            coal.DistanceResult(),
        )

    for (link, robot_shape, robot_placement), is_moving in zip(robot_parts, moving):
        depth = -distance(robot_shape, robot_placement, table_shape, table_placement)
        if is_moving and depth > TABLE_TOLERANCE:
            raise ValueError(
                f"{where}: the robot's {link} reaches {depth * 100:.1f} cm into the table in its "
                "initial configuration"
            )
    for pair in robot.collision_model.collisionPairs:
        (link, shape, placement), (other, other_shape, other_placement) = (
            robot_parts[pair.first],
            robot_parts[pair.second],
        )
        if distance(shape, placement, other_shape, other_placement) < 0.0:
            raise ValueError(
                f"{where}: the robot's {link} intersects its {other} in its initial configuration"
            )
    for body in bodies:
        what = body.name.replace("_", " ") if body.role == "obstacle" else f"the {body.name}"
        shape, placement = (
            coal_shape(body.shape, body.dimensions),
            se3(body.position, body.orientation),
        )
        if body.role == "lid":
            placement = placement * lid_geometry_offset(situation.object_dimensions[0])
        if body.role != "obstacle":
            depth = -distance(shape, placement, table_shape, table_placement)
            if depth > TABLE_TOLERANCE:
                raise ValueError(
                    f"{where}: {what} ({body.shape}) reaches {depth * 100:.1f} cm into the table"
                )
        for link, robot_shape, robot_placement in robot_parts:
            if distance(shape, placement, robot_shape, robot_placement) < 0.0:
                raise ValueError(
                    f"{where}: {what} ({body.shape}) intersects the robot's {link} in its "
                    "initial configuration"
                )
    displacement = target_displacement(situation.perturbations)
    if np.any(displacement):
        target = next(body for body in bodies if body.name == "object")
        moved = se3(np.asarray(target.position) + displacement, target.orientation)
        depth = -distance(
            coal_shape(target.shape, target.dimensions), moved, table_shape, table_placement
        )
        if depth > TABLE_TOLERANCE:
            raise ValueError(
                f"{where}: its perturbations move the {target.shape} {depth * 100:.1f} cm into "
                "the table"
            )
    return situation
