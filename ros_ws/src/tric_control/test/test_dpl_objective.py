"""The DPL objectives of the controller (tric_control.objectives, C_DPL of Sec. 5.3.2) without ROS:
the unconstrained QP step follows the policy's step scaled to the control period, in joint space and
in the fingertips' box-frame space, and make_objective refuses models it cannot run. Units: rad, m,
s."""

import math
from dataclasses import replace

import numpy as np
import pytest

from tric_control.motion_rate import MotionRateController
from tric_control.objectives import DPL_WEIGHT, DplObjective, make_objective
from tric_learning.features import FeatureDefinition
from tric_learning.model_file import ModelFile
from tric_learning.training import dpl
from tric_learning.value_function import Scaling
from tric_sim.world.proximity import Closest
from tric_sim.world.robot_model import RobotModel

SPHERE = {"object": (np.array([0.6, 0.0, 0.35]), np.array([0.0, 0.0, 0.0, 1.0]))}
BOX = {
    "object": (np.array([0.6, 0.1, 0.1]), np.array([0.0, 0.0, 0.2474, 0.9689])),
    "lid_edge": (np.array([0.5, 0.1, 0.2]), np.array([0.0, 0.0, 0.2474, 0.9689])),
}
SAMPLE_PERIOD = 0.125
CONTROL_PERIOD = 0.01


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


class NoPairs:
    """A proximity that reports no close pairs: the controller without collision rows."""

    def near(self, q, object_poses, influence):
        return Closest.none(len(q))


def policy_model(
    robot, task: str, kind: str, step_size: float, hidden_units: int = 5, seed: int = 0
) -> ModelFile:
    """A DPL model file with random weights on all features of task, predicting steps of about
    step_size per sample period."""
    rng = np.random.default_rng(seed)
    definition = FeatureDefinition.for_task(task, robot)
    size, outputs = definition.size, len(dpl.target_names(definition, kind))
    scaling = Scaling(np.arange(size), np.full(size, -1.0), np.full(size, 1.0), size)
    policy = dpl.DplPolicy(
        scaling,
        rng.normal(0, 0.1, (hidden_units, size)),
        rng.normal(0, 0.1, hidden_units),
        rng.normal(0, step_size, (outputs, hidden_units)),
        rng.normal(0, step_size, outputs),
    )
    return ModelFile(
        kind, definition, dpl.policy_arrays(policy), {"sample_period_s": SAMPLE_PERIOD}
    )


def middle(robot):
    """The middle of the joint ranges: no joint limit is near."""
    return 0.5 * (robot.lower + robot.upper)


def test_joint_step_is_the_predicted_step_scaled_to_the_control_period(robot):
    """min |dq|^2 + w |dq - s pi|^2 gives dq = w / (w + 1) s pi, s = period / sample period."""
    model = policy_model(robot, "grasp", "dpl_joint", 0.02)
    objective = make_objective(model, robot, CONTROL_PERIOD)
    assert isinstance(objective, DplObjective)
    q = middle(robot)
    predicted = dpl.load_policy(model).predict(objective.features(q, SPHERE))
    expected = DPL_WEIGHT / (DPL_WEIGHT + 1) * CONTROL_PERIOD / SAMPLE_PERIOD * predicted
    assert np.all(np.abs(expected) < robot.velocity_limits * CONTROL_PERIOD)  # no bound is active
    tick = MotionRateController(robot, NoPairs(), objective, CONTROL_PERIOD).tick(q, SPHERE)
    np.testing.assert_allclose(tick.step, expected, atol=1e-7)
    np.testing.assert_allclose(tick.target, q + expected, atol=1e-7)
    assert math.isnan(tick.value) and tick.gradient_norm > 0 and not tick.active


def test_finger_step_follows_the_predicted_fingertip_step(robot):
    """dpl_finger: min |dq|^2 + w |J_f dq - s v|^2 gives dq = (w J_f^T J_f + I)^-1 w J_f^T s v,
    which moves the fingertips nearly by s v (J_f's smallest singular value here is 0.04, so w
    s_min^2 = 2: the |dq|^2 term still has a say along it)."""
    model = policy_model(robot, "open_box", "dpl_finger", 0.005)
    objective = make_objective(model, robot, CONTROL_PERIOD)
    q = robot.home + 0.1
    y, jacobian = objective.features.with_jacobian(q, BOX)
    rows = jacobian[dpl.finger_rows(model.definition)]
    wanted = CONTROL_PERIOD / SAMPLE_PERIOD * dpl.load_policy(model).predict(y)
    expected = np.linalg.solve(
        DPL_WEIGHT * rows.T @ rows + np.eye(robot.n_joints), DPL_WEIGHT * rows.T @ wanted
    )
    assert np.all(np.abs(expected) < robot.velocity_limits * CONTROL_PERIOD)  # no bound is active
    tick = MotionRateController(robot, NoPairs(), objective, CONTROL_PERIOD).tick(q, BOX)
    np.testing.assert_allclose(tick.step, expected, atol=1e-7)
    moved = rows @ tick.step
    assert moved @ wanted > 0.95 * np.linalg.norm(moved) * np.linalg.norm(wanted)


def test_make_objective_builds_both_kinds_and_refuses_what_it_cannot_run(robot):
    joint = policy_model(robot, "grasp", "dpl_joint", 0.02)
    finger = policy_model(robot, "open_box", "dpl_finger", 0.005)
    assert make_objective(joint, robot).rows is None
    assert make_objective(joint, robot).step_scale == pytest.approx(0.08)
    assert len(make_objective(finger, robot).rows) == 6

    grasp_finger = ModelFile("dpl_finger", joint.definition, joint.arrays, joint.info)
    other_robot = replace(joint.definition, robot_model="other_arm:0123")
    refusals = [
        (grasp_finger, "dpl_finger needs the 'box' landmark"),
        (
            ModelFile("dpl_joint", other_robot, joint.arrays, joint.info),
            "made for another robot: 'other_arm', not 'tric_arm_hand'",
        ),
        (
            ModelFile(
                "dpl_joint",
                joint.definition,
                {k: v for k, v in joint.arrays.items() if k != "w2"},
                joint.info,
            ),
            "the dpl_joint model file lacks the array 'w2'",
        ),
        (
            ModelFile("dpl_joint", finger.definition, joint.arrays, joint.info),
            "input arrays have inconsistent shapes",
        ),
        (
            ModelFile("dpl_joint", joint.definition, joint.arrays, {}),
            "has no usable 'sample_period_s'",
        ),
        (
            ModelFile("dpl_joint", joint.definition, joint.arrays, {"sample_period_s": -0.1}),
            "sample_period_s must be finite and positive",
        ),
        (
            ModelFile("svm", joint.definition, joint.arrays, joint.info),
            "model kind 'svm' cannot be run",
        ),
    ]
    for model, message in refusals:
        with pytest.raises(ValueError, match=message):
            make_objective(model, robot)
    with pytest.raises(ValueError, match="the control period must be finite and positive"):
        make_objective(joint, robot, period=0.0)
