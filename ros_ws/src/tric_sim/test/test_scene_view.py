"""The viewer's scene (tric_sim.viz.scene_view): the robot's primitives and transforms against
Pinocchio's collision model and kinematics, the scene's primitives against the situation's geometry;
and their messages (tric_sim.viz.scene_messages)."""

import json

import numpy as np
import pinocchio as pin
import pytest
from visualization_msgs.msg import Marker

from tric_msgs.msg import ControllerStatus
from tric_sim.viz import scene_messages, scene_view
from tric_sim.world import scene, situations
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture(scope="module")
def view(robot):
    return scene_view.RobotView(robot)


def random_configurations(robot, count, seed=0):
    return np.random.default_rng(seed).uniform(
        robot.lower, robot.upper, size=(count, robot.n_joints)
    )


def world_pose(placements, primitive):
    return placements[primitive.frame] * scene.se3(primitive.position, primitive.orientation)


def test_link_frames_follow_the_kinematic_model(robot, view):
    """Composing the static and the moving transforms from "world" gives Pinocchio's placement of
    every URDF link, the mimic-driven knuckle included."""
    links = [frame.name for frame in robot.model.frames if frame.type == pin.FrameType.BODY]
    assert "finger_3_knuckle_link" in links and "palm_center" in links
    for q in random_configurations(robot, 5):
        placements = scene_view.frame_placements(view.static, view.transforms(q))
        robot.forward(q)
        for link in links:
            expected = robot.frame_placement(link)
            assert np.allclose(placements[link].translation, expected.translation, atol=1e-9), link
            assert np.allclose(placements[link].rotation, expected.rotation, atol=1e-9), link


def test_link_primitives_are_the_collision_model(robot, view):
    """One primitive per collision geometry, of the same shape and size, at the same world pose."""
    geometries = {g.name: g for g in robot.collision_model.geometryObjects}
    assert len(view.primitives) == len(geometries) == 21
    q = random_configurations(robot, 1, seed=3)[0]
    pin.updateGeometryPlacements(
        robot.model, robot.data, robot.collision_model, robot.collision_data, q
    )
    placements = scene_view.frame_placements(view.static, view.transforms(q))
    for primitive in view.primitives:
        link, index = primitive.id.split("/")[1:]
        name = f"{link}_{index}"
        geometry = geometries[name].geometry
        if primitive.shape == "cylinder":
            expected = (2 * geometry.radius, 2 * geometry.radius, 2 * geometry.halfLength)
        elif primitive.shape == "sphere":
            expected = (2 * geometry.radius,) * 3
        else:
            expected = tuple(2 * geometry.halfSide)
        assert np.allclose(primitive.size, expected), name
        world = world_pose(placements, primitive)
        reference = robot.collision_data.oMg[robot.collision_model.getGeometryId(name)]
        assert np.allclose(world.homogeneous, reference.homogeneous, atol=1e-9), name
        assert primitive.group == "robot" and len(primitive.color) == 4


@pytest.mark.parametrize("name", ["sphere_test_00_obstacle", "cylinder_test_01", "box_test_02"])
def test_scene_primitives_are_the_situation_bodies(name):
    """Every body of the simulator's scene, its extents and its world pose (the lid's plate offset
    from its hinge frame), placed through the objects' frames."""
    situation = situations.find_situation(name)
    primitives = {p.id: p for p in scene_view.scene_primitives(situation)}
    bodies = scene.scene_bodies(situation)
    assert sorted(primitives) == sorted(f"scene/{b.name}" for b in bodies)
    poses = scene_view.initial_object_poses(situation)
    assert "table" not in poses
    placements = scene_view.frame_placements(scene_view.object_transforms(poses))
    for body in bodies:
        primitive = primitives[f"scene/{body.name}"]
        assert primitive.shape == body.shape and primitive.group == "scene"
        expected = scene.se3(body.position, body.orientation)
        if body.role == "lid":
            expected = expected * scene.lid_geometry_offset(situation.object_dimensions[0])
        assert np.allclose(
            world_pose(placements, primitive).homogeneous, expected.homogeneous, atol=1e-12
        ), body.name
    if situation.object_kind == "sphere":
        assert primitives["scene/object"].size == pytest.approx(
            (2 * situation.object_dimensions[0],) * 3
        )
        assert primitives["scene/obstacle_0"].size == pytest.approx(
            situation.obstacles[0].dimensions
        )
    elif situation.object_kind == "cylinder":
        height, radius = situation.object_dimensions
        assert primitives["scene/object"].size == pytest.approx((2 * radius, 2 * radius, height))
    else:
        side = situation.object_dimensions[0]
        assert primitives["scene/object"].size == pytest.approx((side,) * 3)
        assert primitives["scene/lid"].size == pytest.approx(scene.lid_extents(side))
        assert primitives["scene/table"].frame == scene_view.WORLD


def test_quaternion_product_composes_rotations():
    rng = np.random.default_rng(1)
    a, b = rng.normal(size=(2, 6, 4))
    a /= np.linalg.norm(a, axis=1, keepdims=True)
    b /= np.linalg.norm(b, axis=1, keepdims=True)
    product = scene_view.quaternion_product(a, b)
    for k in range(6):
        rotation = lambda v: pin.Quaternion(v[3], v[0], v[1], v[2]).matrix()  # noqa: E731
        assert np.allclose(rotation(product[k]), rotation(a[k]) @ rotation(b[k]))


def test_marker_array_holds_every_primitive(view):
    situation = situations.find_situation("box_test_02")
    primitives = view.primitives + scene_view.scene_primitives(situation)
    markers = scene_messages.marker_array(primitives, 2_500_000_000).markers
    assert markers[0].action == Marker.DELETEALL and len(markers) == len(primitives) + 1
    assert len({(m.ns, m.id) for m in markers[1:]}) == len(primitives)
    for marker, primitive in zip(markers[1:], primitives):
        assert marker.header.frame_id == primitive.frame and marker.ns == primitive.group
        assert marker.type == scene_messages.MARKER_TYPES[primitive.shape] and marker.frame_locked
        assert (marker.scale.x, marker.scale.y, marker.scale.z) == pytest.approx(primitive.size)
        assert (marker.header.stamp.sec, marker.header.stamp.nanosec) == (2, 500_000_000)


def test_status_fields_are_json(view):
    status = ControllerStatus(
        state=ControllerStatus.RUNNING,
        step=7,
        value=float("nan"),
        value_rate=0.1,
        gradient_norm=2.0,
        step_norm=0.01,
        min_distance=float("inf"),
        tick_time_ms=0.4,
        active_constraints=["collision:palm_link/table"],
        feature_names=["d[palm,object]"],
        feature_values=[0.25],
        feature_gradients=[float("nan")],
    )
    status.header.stamp.sec = 3
    fields = scene_messages.status_fields(status)
    assert json.loads(json.dumps(fields, allow_nan=False)) == fields
    assert (
        fields["value"] is None
        and fields["min_distance"] is None
        and fields["feature_gradients"] == [None]
    )
    assert fields["stamp_ns"] == 3_000_000_000 and fields["active_constraints"] == [
        "collision:palm_link/table"
    ]
    assert set(fields) == set(scene_messages.STATUS_FIELDS) | {"stamp_ns", "phase"}
    assert fields["phase"] == "descending f"
    status.state = ControllerStatus.GRIPPING
    assert scene_messages.status_fields(status)["phase"] == "at rest, gripping"
