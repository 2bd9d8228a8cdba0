"""Hard negatives: rollout states as L_n contrasts, paired with the nearest demonstration step and
weighted by their distance to the path ahead."""

import pathlib

import numpy as np
import pytest

from tric_control.study.hard_negatives import contrasts, train_with_hard_negatives
from tric_learning.bags.loader import bag_paths, load_dataset
from tric_learning.training.samples import step_offsets
from tric_learning.training.value import TrainingConfig, train
from tric_sim.world.robot_model import RobotModel

BAGS = pathlib.Path(__file__).resolve().parents[4] / "bags" / "sphere"


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture(scope="module")
def demos(robot):
    return load_dataset(bag_paths([BAGS])[:2], robot)


def test_a_state_on_the_path_costs_nothing_and_one_off_it_its_distance(robot, demos):
    demo = demos.demos[1]
    on_path = demo.q[10]
    off_path = demo.q[10] + np.r_[np.zeros(7), np.full(7, 0.3)]  # the hand closed further
    states = [[], [(on_path, demo.object_poses[10]), (off_path, demo.object_poses[10])]]
    found = contrasts(demos, robot, states)
    offset = step_offsets(demos)[1]
    # q_{t-1} = q_10 is nearest
    assert found.step[0] == offset + 11
    # the off-path state's pairing
    t = found.step[1] - offset
    nearest = np.argmin(np.linalg.norm(demo.q[:-1] - off_path, axis=1)) + 1
    assert t == nearest
    assert found.weight[0] == pytest.approx(0.0, abs=1e-12)
    # well off the path ahead of t
    assert found.weight[1] > 0.1
    # the features of the state itself
    np.testing.assert_allclose(found.y[0], demo.y[10], atol=1e-9)
    assert found.kept_per_step.sum() == 2 and found.kept_per_step[offset + 11] >= 1


def test_rounds_train_again_with_the_rollout_states(robot, demos):
    config = TrainingConfig(hidden_units=3, noisy_samples=10, max_iterations=5)
    rounds = []
    result = train_with_hard_negatives(
        demos,
        robot,
        config,
        rounds=1,
        max_steps=60,
        every=20,
        progress=lambda round_, k: rounds.append((round_, k)),
    )
    assert rounds == [(0, 0), (0, 1)]
    # the same noisy samples (the same seed) plus one contrast per rollout state: a state at tick 0
    # and at most at ticks 20 and 40 of each of the two situations
    plain = train(demos, robot, config)
    later_steps = sum(demo.length - 1 for demo in demos.demos)
    added = (result.mean_samples_per_step - plain.mean_samples_per_step) * later_steps
    assert added == pytest.approx(round(added), abs=1e-9) and 2 <= round(added) <= 6
    with pytest.raises(ValueError, match="rounds must be >= 0"):
        train_with_hard_negatives(demos, robot, config, rounds=-1, max_steps=60)
