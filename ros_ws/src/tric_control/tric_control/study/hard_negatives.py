"""Hard negatives: training again on the states the learned controller visits. ROS-free.

The paper's noisy samples (Sec. 3.2.2) stand in for "all other possible motions", and it notes
(Sec. 4.2.1) that they approximate the most offending false answer. Here the offenders are found by
running the learned controller itself (offline, on the physics, no teacher and no hidden metric) in
the training situations: every `every` ticks its state q becomes a contrast for L_n, paired with the
demonstration step whose joint positions are nearest (the step the controller seems to be at) and
weighted, like a noisy sample, by its distance d_curve to the demonstration's path from that step
on (Eq. 14-15): a state on the demonstrated path costs nothing, one that strayed (the fingers
closed before the palm arrived, say) is pushed up in f. Then f is trained again on the
demonstrations, the noisy samples and every round's rollout states. Units: rad, ticks.
"""

import numpy as np

from tric_control.episode_runner import EpisodeRunner
from tric_control.motion_rate import MotionRateController
from tric_control.objectives import CONTROL_PERIOD, make_objective
from tric_learning import model_file
from tric_learning.features import FeatureMap
from tric_learning.training.dataset import Dataset
from tric_learning.training.samples import NoisySamples, d_curve, joined, step_offsets
from tric_learning.training.value import TrainingConfig, TrainingResult, train
from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.world.proximity import Proximity
from tric_sim.world.robot_model import RobotModel


def rollout_states(
    world: PhysicsWorld, robot: RobotModel, situation, objective, max_steps: int, every: int
) -> list:
    """[(q (n,), object poses)] of the controller's states every `every` ticks of one episode."""
    world.reset(situation)
    controller = MotionRateController(robot, Proximity(robot, situation), objective, CONTROL_PERIOD)
    runner = EpisodeRunner(robot, controller, max_steps, CONTROL_PERIOD)
    states, outcome, tick = [], None, 0
    while outcome is None:
        q, _ = world.joint_state()
        poses = world.object_poses()
        if tick % every == 0:
            states.append((q, poses))
        decided = runner.step(q, poses)
        world.command(decided.command)
        world.step()
        outcome, tick = decided.outcome, tick + 1
    return states


def contrasts(dataset: Dataset, robot: RobotModel, demo_states: list) -> NoisySamples:
    """The rollout states of each demonstration's situation (demo_states[i]: [(q, poses)]) as L_n
    contrasts: each paired with the demonstration step t >= 1 whose q_{t-1} is nearest (noisy
    samples are drawn around q_{t-1}) and weighted by d_curve to the path q_{t-1}, ..., q_{T-1} (so
    that a state on the demonstrated path costs nothing)."""
    features = FeatureMap(dataset.definition, robot)
    offsets = step_offsets(dataset)
    steps, ys, weights = [], [], []
    for i, (demo, states) in enumerate(zip(dataset.demos, demo_states)):
        if not states:
            continue
        qs = np.array([q for q, _ in states])
        distances = np.linalg.norm(qs[:, None, :] - demo.q[None, :-1, :], axis=2)  # (S, T - 1)
        # t in [1, T - 1]
        nearest = np.argmin(distances, axis=1) + 1
        for q, poses, t in zip(qs, (p for _, p in states), nearest):
            steps.append(offsets[i] + t)
            ys.append(features(q, poses))
            weights.append(float(d_curve(q[None, :], demo.q[t - 1 :])[0]))
    kept = np.zeros(offsets[-1], dtype=int)
    np.add.at(kept, np.array(steps, dtype=int), 1)
    return NoisySamples(
        step=np.array(steps, dtype=int),
        y=np.array(ys).reshape(len(ys), -1),
        weight=np.array(weights),
        kept_per_step=kept,
    )


def train_with_hard_negatives(
    dataset: Dataset,
    robot: RobotModel,
    config: TrainingConfig,
    rounds: int,
    max_steps: int,
    every: int = 20,
    progress=None,
) -> TrainingResult:
    """Train f, then `rounds` times: roll the learned controller out in every training situation for
    max_steps ticks, add its states every `every` ticks as contrasts (see contrasts()) and train
    again from scratch on all of them. progress(round, situation index) after each rollout."""
    if rounds < 0 or max_steps < 1 or every < 1:
        raise ValueError("rounds must be >= 0, max_steps and every >= 1")
    result = train(dataset, robot, config)
    extra = None
    world = PhysicsWorld(robot)
    try:
        for round_ in range(rounds):
            objective = make_objective(
                model_file.from_training(result, dataset), robot, CONTROL_PERIOD
            )
            states = []
            for k, demo in enumerate(dataset.demos):
                states.append(
                    rollout_states(world, robot, demo.situation, objective, max_steps, every)
                )
                if progress is not None:
                    progress(round_, k)
            found = contrasts(dataset, robot, states)
            extra = found if extra is None else joined(extra, found)
            result = train(dataset, robot, config, extra_samples=extra)
    finally:
        world.close()
    return result
