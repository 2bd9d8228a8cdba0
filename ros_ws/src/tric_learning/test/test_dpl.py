"""The DPL baseline without ROS (tric_learning.training.dpl): the network fits a hand-made smooth
regression, refused hyper-parameters, training on recorded sphere demonstrations is deterministic
and its model file round-trips, and dpl_finger's targets are the fingertips' steps in the box frame.
Units: rad, m."""

import dataclasses

import numpy as np
import pinocchio as pin
import pytest

from tric_learning.features import FeatureDefinition, FeatureMap
from tric_learning.model_file import ModelFile
from tric_learning.recording import record_offline
from tric_learning.training import dpl
from tric_learning.training.dataset import Dataset, Demo
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture(scope="module")
def sphere_dataset(robot):
    """Three 5 s sphere demonstrations (T = 40)."""
    return record_offline(robot, situations.sphere_grid()[12:15], 5.0)


def synthetic_demo(name, latent, mixing, step_of, period_ns=125_000_000):
    """A demo whose features are a fixed linear image of a latent path (T, 3) and whose joint steps
    are step_of(latent) (T - 1, n): q is their running sum."""
    steps = step_of(latent[:-1])
    q = np.vstack([np.zeros(steps.shape[1]), np.cumsum(steps, axis=0)])
    length, n = q.shape
    y = latent @ mixing
    return Demo(
        name=name,
        situation=None,
        q=q,
        y=y,
        jacobians=np.zeros((length, y.shape[1], n)),
        object_poses=[{}] * length,
        stamps_ns=np.arange(length) * period_ns,
    )


def test_network_fits_a_smooth_regression(robot):
    """y (224,) = M c for a latent point c in [0, 1]^3 on smooth paths; u = 0.02 sin(B c + a)
    (14,): the 60-unit network recovers u on the training steps and between the paths."""
    rng = np.random.default_rng(5)
    definition = FeatureDefinition.for_task("grasp", robot)
    mixing = rng.normal(0.0, 1.0, (3, definition.size))
    gains, phases = rng.normal(0.0, 2.0, (3, robot.n_joints)), rng.uniform(0, np.pi, robot.n_joints)
    step_of = lambda c: 0.02 * np.sin(c @ gains + phases)  # noqa: E731
    time = np.linspace(0.0, 1.0, 40)[:, None]
    paths = [start + (end - start) * time for start, end in rng.uniform(0, 1, (12, 2, 3))]
    dataset = Dataset(
        definition,
        [synthetic_demo(f"path_{k}", path, mixing, step_of) for k, path in enumerate(paths)],
    )
    result = dpl.train_dpl(dataset, robot, dpl.DplConfig(l2=1e-7), "dpl_joint")

    _, targets = dpl.training_pairs(dataset, "dpl_joint")
    assert result.losses["mse"] < 1e-3 * np.mean(targets**2)
    assert result.sample_period_s == pytest.approx(0.125)
    between = rng.uniform(0.2, 0.8, (50, 3))
    errors = result.policy.predict(between @ mixing) - step_of(between)
    assert np.sqrt(np.mean(errors**2)) < 0.05 * np.sqrt(np.mean(targets**2))


@pytest.mark.parametrize(
    "values, message",
    [
        ({"hidden_units": 0}, "hidden_units must be in [1, 1000] for DPL"),
        ({"hidden_units": 1001}, "hidden_units must be in [1, 1000] for DPL"),
        ({"l2": -1e-4}, "l2 must be finite and >= 0"),
        ({"l2": float("nan")}, "l2 must be finite and >= 0"),
        ({"max_iterations": 0}, "max_iterations must be in [1, 100000]"),
        ({"correlation_threshold": 0.0}, "correlation_threshold must be in (0, 1]"),
        ({"seed": -1}, "seed must be in [0, 2^32)"),
    ],
)
def test_config_refusals(values, message):
    with pytest.raises(ValueError) as error:
        dpl.DplConfig(**values).validate()
    assert str(error.value) == message


def test_training_refuses_a_dataset_it_cannot_learn(robot, sphere_dataset):
    with pytest.raises(ValueError, match="unknown DPL kind 'tric'"):
        dpl.train_dpl(sphere_dataset, robot, dpl.DplConfig(), "tric")
    with pytest.raises(ValueError, match="dpl_finger needs the 'box' landmark .* task 'grasp'"):
        dpl.train_dpl(sphere_dataset, robot, dpl.DplConfig(), "dpl_finger")
    still = Dataset(
        sphere_dataset.definition,
        [
            synthetic_demo(
                "still", np.zeros((5, 3)), np.zeros((3, 224)), lambda c: np.zeros((len(c), 14))
            )
        ],
    )
    with pytest.raises(ValueError, match="the demonstrations do not move"):
        dpl.train_dpl(still, robot, dpl.DplConfig(), "dpl_joint")


def test_training_is_deterministic_and_its_model_file_round_trips(robot, sphere_dataset, tmp_path):
    config = dpl.DplConfig(hidden_units=20, max_iterations=40, seed=7)
    first, second = (dpl.train_dpl(sphere_dataset, robot, config, "dpl_joint") for _ in range(2))
    np.testing.assert_array_equal(first.policy.w1, second.policy.w1)
    assert first.losses == second.losses and first.iterations == second.iterations
    assert 1 <= first.iterations <= 40
    # the optimizer lowered the loss: one iteration leaves it higher
    once = dpl.train_dpl(
        sphere_dataset, robot, dataclasses.replace(config, max_iterations=1), "dpl_joint"
    )
    assert once.losses["total"] > first.losses["total"]

    path = dpl.to_model_file(first, sphere_dataset).save(tmp_path / "dpl.safetensors")
    loaded = ModelFile.load(path, expected=FeatureDefinition.for_task("grasp", robot))
    assert loaded.kind == "dpl_joint"
    info = loaded.info
    assert info["hyperparameters"] == config.to_dict()
    assert info["dataset_fingerprint"] == sphere_dataset.fingerprint
    assert info["losses"] == first.losses and info["iterations"] == first.iterations
    assert info["targets"] == list(robot.joint_names)
    assert info["robot_profile"] == robot.profile.identity
    assert info["sample_period_s"] == pytest.approx(0.125, abs=1e-3)
    assert info["train_time_s"] == first.train_time_s > 0
    inputs, targets = dpl.training_pairs(sphere_dataset, "dpl_joint")
    assert inputs.shape == (3 * 39, 224) and targets.shape == (3 * 39, robot.n_joints)
    np.testing.assert_array_equal(
        dpl.load_policy(loaded).predict(inputs), first.policy.predict(inputs)
    )
    errors = first.policy.predict(inputs) - targets
    assert first.losses["mse"] == pytest.approx(np.mean(errors**2))
    assert first.losses["mse"] < 0.5 * np.mean(targets**2)


def test_load_policy_refuses_other_kinds_and_broken_arrays(robot, sphere_dataset):
    result = dpl.train_dpl(
        sphere_dataset, robot, dpl.DplConfig(hidden_units=4, max_iterations=5), "dpl_joint"
    )
    model = dpl.to_model_file(result, sphere_dataset)
    with pytest.raises(ValueError, match="is a 'tric' model, not a DPL policy"):
        dpl.load_policy(ModelFile("tric", model.definition, model.arrays))
    arrays = {k: v for k, v in model.arrays.items() if k != "b1"}
    with pytest.raises(ValueError, match="the dpl_joint model file lacks the array 'b1'"):
        dpl.load_policy(ModelFile("dpl_joint", model.definition, arrays))
    arrays = dict(model.arrays, w2=model.arrays["w2"][:6], b2=model.arrays["b2"][:6])
    with pytest.raises(
        ValueError, match=r"output arrays have shapes \(6, 4\) and \(6,\); .* needs 14 outputs"
    ):
        dpl.load_policy(ModelFile("dpl_joint", model.definition, arrays))
    arrays = dict(model.arrays, b1=np.full(4, np.nan))
    with pytest.raises(ValueError, match="b1 has non-finite values"):
        dpl.load_policy(ModelFile("dpl_joint", model.definition, arrays))


def test_finger_targets_are_fingertip_steps_in_the_box_frame(robot):
    """Two configurations around a box turned by 0.5 rad about z: the dpl_finger target of the step
    is R_box^T (x_tip(q1) - x_tip(q0)) for fingertips 2 and 3, worked out from the robot's
    frames."""
    definition = FeatureDefinition.for_task("open_box", robot)
    feature_map = FeatureMap(definition, robot)
    yaw = 0.5
    box = (np.array([0.6, 0.1, 0.1]), np.array([0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2)]))
    poses = {"object": box, "lid_edge": (np.array([0.5, 0.1, 0.2]), box[1])}
    q0 = robot.home.copy()
    q1 = robot.home + np.linspace(-0.05, 0.05, robot.n_joints)
    configurations = [q0, q1, q1]
    y = np.array([feature_map(q, poses) for q in configurations])
    demo = Demo(
        name="box",
        situation=None,
        q=np.array(configurations),
        y=y,
        jacobians=np.zeros((3, definition.size, robot.n_joints)),
        object_poses=[poses] * 3,
        stamps_ns=np.arange(3) * 125_000_000,
    )
    _, targets = dpl.training_pairs(Dataset(definition, [demo]), "dpl_finger")

    rotation = pin.Quaternion(box[1][3], *box[1][:3]).toRotationMatrix()  # w, x, y, z

    def tips(q):
        robot.forward(q)
        return np.concatenate(
            [
                rotation.T @ (robot.frame_placement(f"finger_{k}_tip").translation - box[0])
                for k in (2, 3)
            ]
        )

    np.testing.assert_allclose(targets[0], tips(q1) - tips(q0), atol=1e-12)
    np.testing.assert_allclose(targets[1], 0.0, atol=1e-12)
    assert dpl.target_names(definition, "dpl_finger") == [
        f"p[box->fingertip_{k}].{axis}" for k in (2, 3) for axis in "xyz"
    ]
    with pytest.raises(ValueError, match="dpl_finger needs the 'box' landmark"):
        dpl.finger_rows(FeatureDefinition.for_task("grasp", robot))


def test_the_finger_space_policy_reads_its_own_finger_space_only():
    """dpl_finger's state is its finger space: its input scaling keeps only the fingertip-in-box
    features (each fitted over its own range), whatever the other features do; dpl_joint's keeps
    the task features as TRIC's does."""
    rng = np.random.default_rng(0)
    y = rng.uniform(0, 1, (50, 10))
    y[:, 4] = 2 * y[:, 1]  # a feature that copies another: dropped by the correlation test
    rows = np.array([3, 5, 7])
    finger = dpl.input_scaling(y, 0.995, rows)
    assert finger.kept.tolist() == [3, 5, 7] and finger.size == 10
    np.testing.assert_allclose(finger.low, y[:, rows].min(axis=0))
    np.testing.assert_allclose(finger.high, y[:, rows].max(axis=0))
    assert dpl.input_scaling(y, 0.995).kept.tolist() == [0, 1, 2, 3, 5, 6, 7, 8, 9]
