"""The feature map: values on hand-made configurations, analytic Jacobians, definitions."""

import math

import numpy as np
import pytest
import yaml

from tric_learning.features import FeatureDefinition, FeatureMap
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


def test_sizes_and_names(robot):
    grasp = FeatureDefinition.for_task("grasp", robot)
    box = FeatureDefinition.for_task("open_box", robot)
    assert grasp.size == 224 and len(grasp.landmark_names) == 8 and len(grasp.pairs) == 56
    assert box.size == 80 and len(box.landmark_names) == 5
    assert grasp.feature_names[:4] == (
        "p[object->fingertip_1].x",
        "p[object->fingertip_1].y",
        "p[object->fingertip_1].z",
        "d[object,fingertip_1]",
    )
    assert len(set(grasp.feature_names)) == 224
    assert grasp.fingerprint != box.fingerprint
    assert FeatureDefinition.from_dict(grasp.to_dict()) == grasp
    with pytest.raises(ValueError, match="unknown|no feature definition"):
        FeatureDefinition.for_task("juggle", robot)


def test_values_on_a_hand_made_configuration(robot):
    """Arm straight up (q = 0 for the arm): the palm centre sits on the z axis; an object placed
    0.3 m in front of it, turned 90 degrees about z, must appear where geometry says."""
    definition = FeatureDefinition.for_task("grasp", robot)
    features = FeatureMap(definition, robot)
    q = np.zeros(robot.n_joints)
    robot.forward(q)
    palm = robot.frame_placement("palm_center")
    assert np.allclose(palm.translation[:2], 0.0) and np.allclose(palm.rotation, np.eye(3))
    object_position = palm.translation + np.array([0.3, 0.0, 0.0])
    yaw = (0.0, 0.0, math.sin(math.pi / 4), math.cos(math.pi / 4))
    y = dict(zip(definition.feature_names, features(q, {"object": (tuple(object_position), yaw)})))
    # the object seen from the palm (palm frame = world frame here)
    assert np.allclose(
        [y["p[palm->object].x"], y["p[palm->object].y"], y["p[palm->object].z"]], [0.3, 0, 0]
    )
    # the palm seen from the object, whose x axis points along world y
    assert np.allclose(
        [y["p[object->palm].x"], y["p[object->palm].y"], y["p[object->palm].z"]], [0, 0.3, 0]
    )
    assert math.isclose(y["d[palm,object]"], 0.3) and math.isclose(y["d[object,palm]"], 0.3)


def test_a_grasp_centre_is_a_landmark_where_the_profile_names_one(robot):
    """The Panda's profile names a grasp centre between its pads, the paper's robot none (its 8
    landmarks). An object held there is 0 m from it; moved 1 cm across the pads (the palm's y), its
    distance to the grasp centre grows by 1 cm, to the palm or a fingertip by millimetres only."""
    assert "grasp_centre" not in FeatureDefinition.for_task("grasp", robot).landmark_names
    panda = RobotModel("panda")
    definition = FeatureDefinition.for_task("grasp", panda)
    assert definition.landmark_names[-1] == "grasp_centre" and definition.size == 7 * 6 * 4
    assert "grasp_centre" not in FeatureDefinition.for_task("open_box", panda).landmark_names
    features = FeatureMap(definition, panda)
    panda.forward(panda.home)
    centre = panda.frame_placement(panda.profile.grasp_centre)
    across = centre.rotation[:, 1]
    at = {"object": (tuple(centre.translation), (0.0, 0.0, 0.0, 1.0))}
    moved = {"object": (tuple(centre.translation + 0.01 * across), (0.0, 0.0, 0.0, 1.0))}
    y0 = dict(zip(definition.feature_names, features(panda.home, at)))
    y1 = dict(zip(definition.feature_names, features(panda.home, moved)))
    assert y0["d[object,grasp_centre]"] < 1e-9
    assert math.isclose(y1["d[object,grasp_centre]"], 0.01, rel_tol=1e-6)
    assert math.isclose(y1["p[grasp_centre->object].y"], 0.01, rel_tol=1e-6)
    for other in ("palm", "fingertip_1", "fingertip_2"):
        assert 0 <= y1[f"d[object,{other}]"] - y0[f"d[object,{other}]"] < 0.003


@pytest.mark.parametrize(
    "task, poses",
    [
        ("grasp", {"object": ((0.6, 0.1, 0.3), (0.0, 0.2, 0.0, 0.98))}),
        (
            "open_box",
            {
                "object": ((0.6, 0.0, 0.1), (0.0, 0.0, 0.2, 0.98)),
                "lid_edge": ((0.5, 0.0, 0.2), (0.0, 0.3, 0.95, 0.1)),
            },
        ),
    ],
)
def test_jacobian_matches_finite_differences(robot, task, poses):
    features = FeatureMap(FeatureDefinition.for_task(task, robot), robot)
    rng = np.random.default_rng(0)
    for _ in range(5):
        q = rng.uniform(robot.lower, robot.upper)
        y, jacobian = features.with_jacobian(q, poses)
        assert np.allclose(y, features(q, poses))
        numeric = np.zeros_like(jacobian)
        for j in range(robot.n_joints):
            dq = np.zeros(robot.n_joints)
            dq[j] = 1e-6
            numeric[:, j] = (features(q + dq, poses) - features(q - dq, poses)) / 2e-6
        assert np.abs(jacobian - numeric).max() < 1e-6


def test_features_that_no_joint_moves_are_known(robot):
    """moves_with_q marks the features with a Jacobian: not those between the box, the lid and the
    robot's fixed base, whose Jacobian rows are zero at every configuration."""
    definition = FeatureDefinition.for_task("open_box", robot)
    features = FeatureMap(definition, robot)
    fixed = {definition.landmark_names.index(name) for name in ("box", "lid", "robot_base")}
    still = np.repeat([i in fixed and j in fixed for i, j in definition.pairs], 4)
    assert np.array_equal(features.moves_with_q, ~still)
    assert still.sum() == 4 * 6  # the 6 ordered pairs of the 3 fixed landmarks
    poses = {
        "object": ((0.6, 0.0, 0.1), (0.0, 0.0, 0.2, 0.98)),
        "lid_edge": ((0.5, 0.0, 0.2), (0.0, 0.3, 0.95, 0.1)),
    }
    rng = np.random.default_rng(1)
    configurations = rng.uniform(robot.lower, robot.upper, (5, robot.n_joints))
    jacobians = [features.with_jacobian(q, poses)[1] for q in configurations]
    assert all(np.all(jacobian[~features.moves_with_q] == 0.0) for jacobian in jacobians)
    assert np.all(
        np.any(
            [np.abs(jacobian[features.moves_with_q]).max(axis=1) > 0 for jacobian in jacobians],
            axis=0,
        )
    )


def test_batch_matches_single_evaluations(robot):
    features = FeatureMap(FeatureDefinition.for_task("grasp", robot), robot)
    poses = {"object": ((0.6, 0.1, 0.3), (0.0, 0.0, 0.0, 1.0))}
    qs = np.random.default_rng(1).uniform(robot.lower, robot.upper, (20, robot.n_joints))
    assert np.allclose(features.batch(qs, poses), [features(q, poses) for q in qs], atol=1e-12)
    per_sample = [{"object": ((0.5 + 0.01 * k, 0.0, 0.3), (0.0, 0.0, 0.0, 1.0))} for k in range(20)]
    assert np.allclose(
        features.batch(qs, per_sample), [features(q, p) for q, p in zip(qs, per_sample)], atol=1e-12
    )


def test_missing_object_and_other_robot_are_refused(robot):
    definition = FeatureDefinition.for_task("open_box", robot)
    features = FeatureMap(definition, robot)
    with pytest.raises(ValueError, match="'lid_edge' is missing"):
        features(robot.home, {"object": ((0.6, 0.0, 0.1), (0.0, 0.0, 0.0, 1.0))})
    other = FeatureDefinition(
        definition.task,
        definition.landmark_names,
        definition.landmark_sources,
        definition.pairs,
        definition.joint_names,
        "another_robot:0000",
    )
    with pytest.raises(ValueError, match="another robot: 'another_robot', not 'tric_arm_hand'"):
        FeatureMap(other, robot)


def test_a_definition_is_refused_on_a_robot_of_another_profile(robot, tmp_path):
    """The same URDF under another profile's name is another robot: a definition (and so a model
    or a bag) made for one is refused on the other, naming both."""
    data = yaml.safe_load(robot.profile.path.read_text())
    data.update(
        name="other_arm",
        urdf=str(robot.profile.urdf_path),
        srdf=str(robot.profile.srdf_path),
    )
    path = tmp_path / "other_arm.yaml"
    path.write_text(yaml.safe_dump(data))
    other = RobotModel(path)
    definition = FeatureDefinition.for_task("grasp", robot)
    with pytest.raises(
        ValueError, match="made for another robot: 'tric_arm_hand', not 'other_arm'"
    ):
        FeatureMap(definition, other)
    assert FeatureMap(FeatureDefinition.for_task("grasp", other), other).definition.size == 224
