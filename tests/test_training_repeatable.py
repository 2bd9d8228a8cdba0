"""A seed names one model: the default training on the reference sphere bags, run again in the same
process, gives the session's reference model to the last bit (with PyTorch's default algorithms two
threads gave other weights each run), and leaves PyTorch's global setting as it found it."""

import numpy as np
import torch

from conftest import REFERENCE_BAGS
from tric_learning.training.value import TrainingConfig, train_from_bags
from tric_sim.world.robot_model import RobotModel


def test_the_default_training_gives_the_same_model_twice(reference_sphere_training, tmp_path):
    assert not torch.are_deterministic_algorithms_enabled()
    again = train_from_bags(
        [REFERENCE_BAGS / "sphere"], tmp_path / "again.safetensors", TrainingConfig(), RobotModel()
    )
    assert not torch.are_deterministic_algorithms_enabled()
    first, second = reference_sphere_training.result, again.result
    for name in ("w1", "w2", "w3"):
        assert np.array_equal(getattr(first.model, name), getattr(second.model, name)), name
    assert first.losses == second.losses and first.iterations == second.iterations
    assert 1 <= first.iterations <= TrainingConfig().max_iterations
