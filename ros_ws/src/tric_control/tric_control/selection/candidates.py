"""One candidate: a TRIC training with its own seed, then its rollouts from every demonstration's
start (tric_control.selection.rollouts). A module-level call (candidate()), so that an executor
(tric_control.evaluation.executors) runs candidates side by side in its workers: each computes
with CANDIDATE_THREADS of PyTorch, so a candidate is the same model whether it trained alone or
beside others. ROS-free."""

import pathlib
import tempfile
import time
from dataclasses import dataclass

from tric_control.evaluation.offline import OfflineEvaluator
from tric_control.selection.rollouts import roll_out
from tric_control.selection.settings import CANDIDATE_THREADS
from tric_learning import model_file
from tric_learning.training.dataset import Dataset
from tric_learning.training.lbfgs import torch_threads
from tric_learning.training.value import TrainingConfig, train
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.robot_profile import DEFAULT_ROBOT


@dataclass
class Candidate:
    """A trained candidate: its seed, its model file's bytes, its training record (losses,
    iterations, selected features), its rollouts ([Rollout] in the dataset's order) and the wall
    seconds its training and its rollouts took."""

    seed: int
    model: bytes
    record: dict
    rollouts: list
    train_s: float
    rollout_s: float


def candidate(
    dataset: Dataset,
    config: TrainingConfig,
    max_steps: int = 0,
    controller_options: dict | None = None,
    fit=None,
    lift_test: bool = True,
    robot: str = DEFAULT_ROBOT,
) -> Candidate:
    """Train TRIC on dataset with config (its seed the candidate's) and roll the model out from
    every demonstration's start situation, max_steps ticks at most (0: the task's default), the
    controller built with controller_options (OfflineEvaluator's), the grasps judged with the lift
    test unless lift_test is False. fit(dataset, robot, config) -> a TrainingResult, a
    module-level function (a study's other training procedure; None: training.value.train).
    robot: the robot of the demonstrations, a profile's name or file."""
    started = time.perf_counter()
    with torch_threads(CANDIDATE_THREADS):
        result = (fit or train)(dataset, RobotModel(robot), config)
    train_s = time.perf_counter() - started
    with tempfile.TemporaryDirectory(prefix="tric-candidate-") as folder:
        path = model_file.from_training(result, dataset).save(
            pathlib.Path(folder) / f"candidate_s{config.seed}.safetensors"
        )
        content = path.read_bytes()
    record = {
        "losses": result.losses,
        "iterations": result.iterations,
        "selected_features": result.selected_features,
        "delta": result.delta,
        "rho": result.rho,
    }
    return rolled_out(
        dataset,
        content,
        config.seed,
        record,
        train_s,
        max_steps,
        controller_options,
        lift_test,
        robot,
    )


def rolled_out(
    dataset: Dataset,
    content: bytes,
    seed: int,
    record: dict,
    train_s: float = 0.0,
    max_steps: int = 0,
    controller_options: dict | None = None,
    lift_test: bool = True,
    robot: str = DEFAULT_ROBOT,
) -> Candidate:
    """The Candidate of a trained model (its model file's bytes, content; its seed and training
    record), rolled out from every demonstration's start situation of dataset (as candidate())."""
    started = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="tric-candidate-") as folder:
        path = pathlib.Path(folder) / f"candidate_s{seed}.safetensors"
        path.write_bytes(content)
        evaluator = OfflineEvaluator(
            dataset.definition.task,
            str(path),
            max_steps,
            controller_options=controller_options,
            lift_test=lift_test,
            robot=robot,
        )
        try:
            rollouts = roll_out(evaluator, dataset)
        finally:
            evaluator.close()
    return Candidate(seed, content, record, rollouts, train_s, time.perf_counter() - started)
