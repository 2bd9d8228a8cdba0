"""Noisy samples around the demonstrations and their weights (paper Eq. 12-15).

For demo i and step t (1 <= t < T) the samples are q~ = q_{t-1} + N(0, sigma^2) per joint,
conditioned on the joint limits (each joint drawn from its Gaussian truncated to its limits: the
same distribution as drawing and refusing what falls outside, without the refused draws) and kept
only free of collision with the demo's scene (tric_sim.world.collision), with the objects where they
were at step t - 1 by default: a sample is a perturbation of the state at t - 1, an alternative to
the demonstrated move from it, as Eq. 12 draws it around q_{t-1} (scene_step 0 puts the objects
where they are at t instead; docs/decisions/paper-fidelity.md). The hand may press into the bodies
the task lets it touch by contact_tolerance (m), which admits the teacher's own grip. Each sample's
weight is d_curve: its distance to the demo's path ahead, the polyline q_t, ..., q_{T-1} (Eq.
14-15). With the hold, M more samples are drawn around each demo's last state q_{T-1} and
contrasted with y_{T-1} itself (the teacher holds still at its task's end: staying is the
demonstrated move from there), weighted by their distance to it. Samples do not depend on the value
function, so they are drawn once per training, reproducibly from a seed. Units: rad, m.
"""

import concurrent.futures
import multiprocessing
import signal
import warnings
from dataclasses import dataclass
from typing import cast

import numpy as np
from scipy.special import ndtr, ndtri

from tric_learning.features import FeatureMap
from tric_learning.training.dataset import Dataset
from tric_learning.training.hyperparameters import SAMPLE_CONTACT_TOLERANCE
from tric_sim.world.collision import SceneCollision
from tric_sim.world.robot_model import RobotModel

#: Candidates are drawn in rounds: the first assumes this many per kept sample; later rounds draw
#: for the still missing samples from the acceptance seen so far, at most MAX_DRAWS * M per step
#: and round. Near a grasp few candidates are collision-free (a 0.05 rad turn of an arm joint moves
#: the hand by centimetres): 4 to 20% of them in the last 10 steps of a sphere grasp.
OVERSAMPLING = 1.25
MAX_ROUNDS = 4
MAX_DRAWS = 25
#: Consecutive steps whose objects' surfaces moved by less than this share one collision check with
#: the first step's poses (held objects give by a millimetre or so), m.
POSE_TOLERANCE = 0.002


@dataclass
class NoisySamples:
    """S noisy samples of a dataset.

    step: (S,) index of the demo step each sample is contrasted with, into the dataset's steps
    flattened demo by demo (demo i, step t -> offsets[i] + t). y: (S, d) raw features.
    weight: (S,) d_curve, rad. kept_per_step: (steps,) samples kept per step (<= M).
    """

    step: np.ndarray
    y: np.ndarray
    weight: np.ndarray
    kept_per_step: np.ndarray


def joined(first: NoisySamples, second: NoisySamples) -> NoisySamples:
    """The samples of both sets (of the same dataset), ordered by step."""
    step = np.concatenate([first.step, second.step])
    order = np.argsort(step, kind="stable")
    return NoisySamples(
        step=step[order],
        y=np.concatenate([first.y, second.y])[order],
        weight=np.concatenate([first.weight, second.weight])[order],
        kept_per_step=first.kept_per_step + second.kept_per_step,
    )


def d_curve(points: np.ndarray, path: np.ndarray) -> np.ndarray:
    """Distance (B,) of points (B, n) to the polyline through path (P, n) (Eq. 14)."""
    if len(path) == 1:
        return np.linalg.norm(points - path[0], axis=1)
    starts, ends = path[:-1], path[1:]
    segments = ends - starts  # (P-1, n)
    lengths = np.einsum("sn,sn->s", segments, segments)
    relative = points[:, None, :] - starts[None, :, :]  # (B, P-1, n)
    fraction = np.einsum("bsn,sn->bs", relative, segments) / np.maximum(lengths, 1e-18)
    fraction = np.clip(fraction, 0.0, 1.0)
    closest = relative - fraction[:, :, None] * segments[None, :, :]
    return np.sqrt(np.einsum("bsn,bsn->bs", closest, closest).min(axis=1))


def step_offsets(dataset: Dataset) -> np.ndarray:
    """Index of each demo's first step in the flattened steps, and the total, (N + 1,)."""
    return np.concatenate([[0], np.cumsum([demo.length for demo in dataset.demos])])


def generate(
    dataset: Dataset,
    robot: RobotModel,
    count: int,
    sigma: float,
    seed: int,
    progress=None,
    workers: int = 2,
    contact_tolerance: float = SAMPLE_CONTACT_TOLERANCE,
    scene_step: int = -1,
    hold: bool = False,
) -> NoisySamples:
    """count (M) collision-free noisy samples per demo step t >= 1 (fewer only where MAX_ROUNDS of
    resampling could not find them); progress(done, total) is called after each demo. Demos are
    sampled in `workers` forked processes where the platform allows it, each from its own seed
    (seed, demo index): the result does not depend on the number of workers. contact_tolerance: how
    deep (m) a sample may press into the bodies the task lets the hand touch. scene_step: the
    samples of step t see the objects of step t + scene_step (-1: those of q_{t-1}, around which
    they are drawn; 0: the positive's). hold: also count samples around each demo's last state
    q_{T-1}, contrasted with y_{T-1} itself (the teacher holds still once its task is done: the
    demonstrated move from its end is no move), weighted by their distance to q_{T-1}."""
    if count < 1 or not sigma > 0:
        raise ValueError("the noisy sample count must be >= 1 and sigma > 0")
    if not 0 <= contact_tolerance <= 0.1:
        raise ValueError("the samples' contact tolerance must be in [0, 0.1] m")
    if scene_step not in (0, -1):
        raise ValueError("the samples' scene step must be 0 or -1")
    offsets = step_offsets(dataset)
    results: list = [None] * len(dataset.demos)  # (steps, y, weight) of each demo, once drawn
    job = (dataset, robot, count, sigma, seed, contact_tolerance, scene_step, hold)
    if workers > 1 and len(dataset.demos) > 1 and "fork" in multiprocessing.get_all_start_methods():
        _sample_in_workers(job, workers, results, progress)
    for i in range(len(dataset.demos)):
        if results[i] is None:  # no workers, or a worker died before returning this demo
            results[i] = _demo_samples(dataset, robot, i, *job[2:])
            if progress is not None:
                progress(sum(r is not None for r in results), len(dataset.demos))
    kept = np.zeros(offsets[-1], dtype=int)
    for i, (steps, _, _) in enumerate(results):
        np.add.at(kept, offsets[i] + steps, 1)
    return NoisySamples(
        step=np.concatenate([offsets[i] + r[0] for i, r in enumerate(results)]),
        y=np.concatenate([r[1] for r in results]),
        weight=np.concatenate([r[2] for r in results]),
        kept_per_step=kept,
    )


_JOB: tuple | None = None


def worker_pool(workers: int) -> concurrent.futures.ProcessPoolExecutor:
    """An executor of `workers` forked processes in which SIGTERM and SIGINT act as by default. A
    worker forked from a process where rclpy.init() installed its signal handlers (every node
    executable) would otherwise ignore the SIGTERM with which the executor ends the others when one
    worker died (rclpy's handler only wakes a thread that the fork did not copy)."""
    return concurrent.futures.ProcessPoolExecutor(
        workers,
        mp_context=multiprocessing.get_context("fork"),
        initializer=_default_signal_handling,
    )


def _default_signal_handling():
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    signal.signal(signal.SIGINT, signal.default_int_handler)


def _sample_in_workers(job, workers: int, results: list, progress) -> None:
    """Fill results[i] with demo i's samples from forked worker processes (they inherit job). A
    worker that dies (a process forked from a multi-threaded one may crash: a training in a
    long-running tric-experiments segfaulted in its workers once) leaves its demos None, with a
    warning, for generate to sample here, instead of waiting for ever as a multiprocessing.Pool
    does."""
    global _JOB
    _JOB = job
    executor = worker_pool(workers)
    try:
        futures = [executor.submit(_forked_demo, i) for i in range(len(results))]
        for future in concurrent.futures.as_completed(futures):
            i, result = future.result()
            results[i] = result
            if progress is not None:
                progress(sum(r is not None for r in results), len(results))
    except concurrent.futures.process.BrokenProcessPool as error:
        missing = sum(r is None for r in results)
        warnings.warn(
            f"noisy sampling: a worker process ended abruptly ({error}); sampling the "
            f"{missing} remaining demonstrations in this process",
            RuntimeWarning,
            stacklevel=3,
        )
    finally:
        executor.shutdown(wait=True, cancel_futures=True)
        _JOB = None


def _forked_demo(index: int):
    dataset, robot, *rest = cast(tuple, _JOB)  # set before the workers were forked
    return index, _demo_samples(dataset, robot, index, *rest)


def truncated_gaussian(rng, centres: np.ndarray, sigma: float, lower, upper) -> np.ndarray:
    """Draws (B, n) around centres (B, n), each coordinate from N(centre, sigma^2) conditioned on
    [lower, upper] (n,) by inverse transform sampling: the distribution of plain Gaussian draws
    with those outside the bounds refused (a centre beyond a bound gives draws close inside it)."""
    low = ndtr((lower - centres) / sigma)
    high = ndtr((upper - centres) / sigma)
    uniform = low + rng.random(centres.shape) * (high - low)
    draws = centres + sigma * ndtri(np.clip(uniform, 1e-300, 1.0 - 1e-16))
    return np.clip(draws, lower, upper)


def _demo_samples(
    dataset: Dataset,
    robot: RobotModel,
    index: int,
    count: int,
    sigma: float,
    seed: int,
    contact_tolerance: float,
    scene_step: int,
    hold: bool = False,
):
    """(steps (S,), features (S, d), weights (S,)) of one demo's noisy samples (and its hold's,
    see generate)."""
    demo = dataset.demos[index]
    features = FeatureMap(dataset.definition, robot)
    collision = SceneCollision(robot, demo.situation, contact_tolerance)
    extents = {b.name: collision_extent(b) for b in collision.bodies}
    rng = np.random.default_rng([seed, index])
    poses = demo.object_poses[1 + scene_step :]  # poses[t - 1]: the scene of step t's samples
    chosen_q, chosen_step = [], []
    t = 1
    while t < demo.length:
        # steps whose scenes are that of step t (within POSE_TOLERANCE) form a batch
        end = t + 1
        while (
            end < demo.length
            and _surface_shift(poses[end - 1], poses[t - 1], extents) < POSE_TOLERANCE
        ):
            end += 1
        block = np.arange(t, end)
        need = np.full(len(block), count)
        acceptance = np.full(len(block), 1.0 / OVERSAMPLING)
        for _ in range(MAX_ROUNDS):
            draws = np.minimum(
                np.ceil(need / np.maximum(acceptance, 0.1)).astype(int), MAX_DRAWS * count
            )
            draws[need == 0] = 0
            if not draws.any():
                break
            owner = np.repeat(block, draws)
            candidates = truncated_gaussian(rng, demo.q[owner - 1], sigma, robot.lower, robot.upper)
            valid = collision.collision_free(candidates, poses[t - 1])
            for k, step in enumerate(block):
                mine = np.flatnonzero(valid & (owner == step))[: need[k]]
                if draws[k]:
                    acceptance[k] = max(np.sum(valid & (owner == step)) / draws[k], 1e-3)
                need[k] -= len(mine)
                chosen_q.append(candidates[mine])
                chosen_step.append(np.full(len(mine), step))
        t = end
    if hold:
        # the hold (Eq. 12-16 applied to the demonstration's end): no move from q_{T-1} is the
        # demonstrated one, so samples around it are contrasted with y_{T-1} itself; drawn from a
        # stream of their own, so that the other samples do not change
        last = demo.length - 1
        held = draws_around(
            np.random.default_rng([seed, index, 1]),
            demo.q[last],
            count,
            sigma,
            robot,
            lambda candidates: collision.collision_free(candidates, demo.object_poses[last]),
        )
        chosen_q.append(held)
        chosen_step.append(np.full(len(held), last))
    qs, steps = np.concatenate(chosen_q), np.concatenate(chosen_step)
    if not len(qs):
        raise ValueError(
            f"demo '{demo.name}'"
            + (f" (bag {demo.bag})" if demo.bag else "")
            + f": none of its noisy samples (sigma {sigma:g} rad) is inside the joint limits and "
            "free of collisions; its robot may start in contact with the scene"
        )
    held = np.zeros(len(steps), dtype=bool)
    if hold:
        held[len(steps) - len(chosen_q[-1]) :] = True
    order = np.argsort(steps, kind="stable")
    qs, steps, held = qs[order], steps[order], held[order]
    # a hold sample sees the objects where they are at the demonstration's end
    scenes = [demo.object_poses[s] if h else poses[s - 1] for s, h in zip(steps, held)]
    ys = features.batch(qs, scenes)
    weights = np.empty(len(steps))
    for step in np.unique(steps):
        mine = steps == step
        weights[mine] = d_curve(qs[mine], demo.q[step:])
    return steps, ys, weights


def draws_around(
    rng, centre: np.ndarray, count: int, sigma: float, robot: RobotModel, free
) -> np.ndarray:
    """Up to count collision-free draws (B, n) around centre (n,) (free(candidates) -> (B,) bool),
    in at most MAX_ROUNDS rounds of at most MAX_DRAWS * count candidates."""
    kept: list = []
    need, acceptance = count, 1.0 / OVERSAMPLING
    for _ in range(MAX_ROUNDS):
        if need == 0:
            break
        draws = min(int(np.ceil(need / max(acceptance, 0.1))), MAX_DRAWS * count)
        candidates = truncated_gaussian(
            rng, np.repeat(centre[None, :], draws, axis=0), sigma, robot.lower, robot.upper
        )
        valid = np.flatnonzero(free(candidates))
        acceptance = max(len(valid) / draws, 1e-3)
        kept.append(candidates[valid[:need]])
        need -= len(kept[-1])
    return np.concatenate(kept) if kept else np.empty((0, len(centre)))


def collision_extent(body) -> float:
    """How far a body's surface moves per radian it turns about its frame's origin, at most, m
    (0 for a sphere about its centre)."""
    if body.shape == "sphere":
        return 0.0
    if body.role == "lid":  # turning about the hinge
        return float(np.linalg.norm(body.dimensions))
    return float(np.linalg.norm(body.dimensions)) / 2


def _surface_shift(a: dict, b: dict, extents: dict) -> float:
    """Largest displacement of any object's surface between two object-pose dicts, m (inf if the
    objects differ)."""
    if a.keys() != b.keys():
        return float("inf")
    shift = 0.0
    for name in a:
        (pa, qa), (pb, qb) = a[name], b[name]
        angle = 2 * np.arccos(min(1.0, abs(float(np.dot(qa, qb)))))
        shift = max(
            shift, float(np.linalg.norm(np.subtract(pa, pb))) + angle * extents.get(name, 0.0)
        )
    return shift
