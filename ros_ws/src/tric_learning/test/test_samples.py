"""The noisy samples of L_n (tric_learning.training.samples.generate, Eq. 12-15) on two recorded
sphere demonstrations: at most M per step t >= 1, at least half of M on every one (the grasp's end
included), inside the joint limits and collision-free in the scene of step t - 1 (the hand pressing
into the sphere by at most the contact tolerance); drawn around q_{t-1} with standard deviation
sigma, conditioned on the joint limits (checked with the collision check accepting everything, so
that no draw is refused); their features at the poses of step t - 1, or of step t when asked;
their weights d_curve to the path ahead; the same samples from a seed whatever the number of
workers. Units: rad."""

import os

import numpy as np
import pytest

from tric_learning.features import FeatureMap
from tric_learning.recording import record_offline
from tric_learning.training import samples
from tric_sim.world import situations
from tric_sim.world.collision import SceneCollision
from tric_sim.world.robot_model import RobotModel

COUNT, SIGMA, SEED = 30, 0.05, 4


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture(scope="module")
def dataset(robot):
    return record_offline(robot, situations.sphere_grid()[4:6], 5.0)


class SeenFeatureMap(FeatureMap):
    """A FeatureMap that keeps the configurations (B, n) of every batch it is asked for."""

    seen = []

    def batch(self, configurations, object_poses):
        SeenFeatureMap.seen.append(np.array(configurations))
        return super().batch(configurations, object_poses)


class NothingCollides(SceneCollision):
    """The scene's collision check, taking every configuration for collision-free."""

    def collision_free(self, configurations, object_poses):
        return np.ones(len(configurations), dtype=bool)


def draw(robot, dataset, collision=SceneCollision):
    """(the samples generate() draws in this process with the given collision check, their
    configurations (S, n))."""
    monkeypatch = pytest.MonkeyPatch()
    monkeypatch.setattr(samples, "FeatureMap", SeenFeatureMap)
    monkeypatch.setattr(samples, "SceneCollision", collision)
    SeenFeatureMap.seen = []
    try:
        noisy = samples.generate(dataset, robot, COUNT, SIGMA, SEED, workers=1)
    finally:
        monkeypatch.undo()
    assert len(SeenFeatureMap.seen) == len(dataset.demos)  # one batch per demo
    return noisy, np.concatenate(SeenFeatureMap.seen)


@pytest.fixture(scope="module")
def drawn(robot, dataset):
    return draw(robot, dataset)


def demo_of_each_sample(dataset, noisy):
    """(demo index (S,), step within its demo (S,)) of each sample."""
    offsets = samples.step_offsets(dataset)
    demo = np.searchsorted(offsets, noisy.step, side="right") - 1
    return demo, noisy.step - offsets[demo]


def test_each_later_step_gets_at_most_m_collision_free_samples_inside_the_limits(
    robot, dataset, drawn
):
    noisy, qs = drawn
    offsets = samples.step_offsets(dataset)
    assert np.all(noisy.kept_per_step[offsets[:-1]] == 0)  # step 0 has no step before it
    assert (
        np.all(noisy.kept_per_step <= COUNT)
        and noisy.kept_per_step[offsets[:-1] + 1].tolist() == [COUNT] * 2
    )
    assert np.array_equal(np.bincount(noisy.step, minlength=offsets[-1]), noisy.kept_per_step)
    assert np.all(np.diff(noisy.step) >= 0) and len(qs) == len(noisy.y) == len(noisy.weight) == len(
        noisy.step
    )
    assert np.all(noisy.kept_per_step[later_steps(noisy, offsets)] >= COUNT / 2)
    assert np.all((qs >= robot.lower) & (qs <= robot.upper))
    demo, step = demo_of_each_sample(dataset, noisy)
    for i, recorded in enumerate(dataset.demos):
        collision = SceneCollision(robot, recorded.situation, samples.SAMPLE_CONTACT_TOLERANCE)
        extents = {body.name: samples.collision_extent(body) for body in collision.bodies}
        poses = recorded.object_poses
        for t in np.unique(step[demo == i]):
            mine = qs[(demo == i) & (step == t)]
            for q in mine[~collision.collision_free(mine, poses[t - 1])]:
                # steps whose objects moved by less than POSE_TOLERANCE share the check of the first
                # one
                assert any(
                    samples._surface_shift(poses[s], poses[t - 1], extents) < samples.POSE_TOLERANCE
                    and collision.collision_free(q[None], poses[s])[0]
                    for s in range(t - 1)
                ), (i, t)


def later_steps(noisy, offsets) -> np.ndarray:
    """The flattened indices of every step t >= 1."""
    return np.setdiff1d(np.arange(len(noisy.kept_per_step)), offsets[:-1])


def test_a_tighter_contact_tolerance_keeps_fewer_samples_at_the_grasp(robot, dataset, drawn):
    """At 5 mm the teacher's own grip (8 to 9 mm into the sphere) counts as a collision, and the
    grasp's last steps keep fewer of their M samples."""
    noisy, _ = drawn
    tight = samples.generate(dataset, robot, COUNT, SIGMA, SEED, workers=1, contact_tolerance=0.005)
    last = np.concatenate([np.arange(end - 5, end) for end in samples.step_offsets(dataset)[1:]])
    assert tight.kept_per_step[last].sum() < noisy.kept_per_step[last].sum()


def test_truncated_draws_follow_the_gaussian_within_the_bounds():
    """Each coordinate from N(centre, sigma^2) conditioned on its bounds: inside them always; a
    centre on a bound gives the half-normal (mean sigma sqrt(2 / pi) away from it); a centre far
    from both the plain Gaussian; a centre beyond a bound draws close inside it."""
    rng = np.random.default_rng(0)
    count = 20000
    centres = np.tile([0.0, 0.5, 1.3], (count, 1))
    draws = samples.truncated_gaussian(rng, centres, SIGMA, np.zeros(3), np.ones(3))
    assert np.all((draws >= 0.0) & (draws <= 1.0))
    half = draws[:, 0]
    expected = SIGMA * np.sqrt(2 / np.pi)
    assert abs(half.mean() - expected) < 4 * SIGMA / np.sqrt(count)
    middle = draws[:, 1] - 0.5
    assert abs(middle.mean()) < 4 * SIGMA / np.sqrt(count)
    assert abs(middle.std() / SIGMA - 1) < 4 / np.sqrt(2 * (count - 1))
    assert np.all(draws[:, 2] > 1.0 - 2 * SIGMA)


def test_samples_are_gaussian_around_the_previous_step(robot, dataset):
    """With nothing refused by the collision check: M samples at every step t >= 1 (the joint
    limits refuse none: the draws are conditioned on them), and q~ - q_{t-1} of mean 0 and standard
    deviation sigma (within 4 standard errors of the estimates) on the joints more than 4 sigma from
    both limits (near a limit the draws are cut; a cut of another joint does not bias this
    one's)."""
    noisy, qs = draw(robot, dataset, NothingCollides)
    offsets = samples.step_offsets(dataset)
    previous_of_step = np.concatenate(
        [np.vstack([demo.q[:1], demo.q[:-1]]) for demo in dataset.demos]
    )
    assert np.all(noisy.kept_per_step[later_steps(noisy, offsets)] == COUNT)
    demo, step = demo_of_each_sample(dataset, noisy)
    previous = previous_of_step[noisy.step]
    offsets = (qs - previous)[
        (previous - robot.lower > 4 * SIGMA) & (robot.upper - previous > 4 * SIGMA)
    ]
    count = len(offsets)
    # most joints are far from their limits
    assert count > 10 * COUNT * len(noisy.kept_per_step)
    assert abs(offsets.mean()) < 4 * SIGMA / np.sqrt(count)
    assert abs(offsets.std() / SIGMA - 1) < 4 / np.sqrt(2 * (count - 1))


def test_features_and_weights_of_each_sample(robot, dataset, drawn):
    """y~ = phi(q~) with the objects where they were at step t - 1 (q~ perturbs the state at t - 1);
    the weight is d_curve, q~'s distance to the demonstration's path from q_t on (Eq. 14-15)."""
    noisy, qs = drawn
    demo, step = demo_of_each_sample(dataset, noisy)
    features = FeatureMap(dataset.definition, robot)
    poses = [dataset.demos[i].object_poses[t - 1] for i, t in zip(demo, step)]
    np.testing.assert_allclose(noisy.y, features.batch(qs, poses), rtol=0, atol=1e-12)
    for k in range(len(qs)):
        path = dataset.demos[demo[k]].q[step[k] :]
        assert noisy.weight[k] == pytest.approx(
            float(samples.d_curve(qs[k : k + 1], path)[0]), abs=1e-12
        )
    assert np.all(noisy.weight > 0)


def test_samples_may_see_the_scene_of_the_step_they_are_contrasted_with(robot, dataset):
    """scene_step 0: y~ = phi(q~) with the objects where they are at step t."""
    monkeypatch = pytest.MonkeyPatch()
    monkeypatch.setattr(samples, "FeatureMap", SeenFeatureMap)
    SeenFeatureMap.seen = []
    try:
        noisy = samples.generate(dataset, robot, COUNT, SIGMA, SEED, workers=1, scene_step=0)
    finally:
        monkeypatch.undo()
    qs = np.concatenate(SeenFeatureMap.seen)
    demo, step = demo_of_each_sample(dataset, noisy)
    poses = [dataset.demos[i].object_poses[t] for i, t in zip(demo, step)]
    features = FeatureMap(dataset.definition, robot)
    np.testing.assert_allclose(noisy.y, features.batch(qs, poses), rtol=0, atol=1e-12)
    with pytest.raises(ValueError, match="scene step must be 0 or -1"):
        samples.generate(dataset, robot, COUNT, SIGMA, SEED, scene_step=1)


def test_a_seed_gives_the_same_samples_with_any_number_of_workers(robot, dataset, drawn):
    noisy, _ = drawn
    forked = samples.generate(dataset, robot, COUNT, SIGMA, SEED, workers=2)
    for name in ("step", "y", "weight", "kept_per_step"):
        assert np.array_equal(getattr(forked, name), getattr(noisy, name)), name
    other = samples.generate(dataset.subset(1), robot, COUNT, SIGMA, SEED + 1, workers=1)
    assert not np.array_equal(other.y[:COUNT], noisy.y[:COUNT])


def _dies_on_the_first_demo(index: int):
    """samples._forked_demo in a worker that crashes on demo 0."""
    if index == 0:
        os._exit(1)
    return _FORKED_DEMO(index)


_FORKED_DEMO = samples._forked_demo


def test_a_worker_that_dies_leaves_its_demos_to_the_calling_process(
    robot, dataset, drawn, monkeypatch
):
    """A worker process that ends abruptly (a segfault in a fork of a multi-threaded process, seen
    once in tric-experiments) gives a RuntimeWarning and the same samples, not a wait for ever."""
    noisy, _ = drawn
    monkeypatch.setattr(samples, "_forked_demo", _dies_on_the_first_demo)
    seen = []
    with pytest.warns(RuntimeWarning, match="a worker process ended abruptly"):
        rescued = samples.generate(
            dataset,
            robot,
            COUNT,
            SIGMA,
            SEED,
            workers=2,
            progress=lambda done, total: seen.append((done, total)),
        )
    for name in ("step", "y", "weight", "kept_per_step"):
        assert np.array_equal(getattr(rescued, name), getattr(noisy, name)), name
    assert seen[-1] == (2, 2)


@pytest.mark.parametrize("count, sigma", [(0, SIGMA), (COUNT, 0.0)])
def test_bad_counts_and_sigmas_are_refused(robot, dataset, count, sigma):
    with pytest.raises(ValueError, match="noisy sample count must be >= 1 and sigma > 0"):
        samples.generate(dataset, robot, count, sigma, SEED)


def test_the_hold_adds_samples_around_each_demonstration_s_end(robot, dataset, drawn):
    """hold: the samples of every step are those without it, bit for bit (a stream of their own),
    and each demo's last step gains up to M more, drawn around its last state q_{T-1} (not q_{T-2}),
    contrasted with y_{T-1}, seeing the objects where they are at its end, weighted by their
    distance to q_{T-1}; collision-free and inside the limits as every sample."""
    plain, _ = drawn
    monkeypatch = pytest.MonkeyPatch()
    monkeypatch.setattr(samples, "FeatureMap", SeenFeatureMap)
    SeenFeatureMap.seen = []
    try:
        held = samples.generate(dataset, robot, COUNT, SIGMA, SEED, workers=1, hold=True)
    finally:
        monkeypatch.undo()
    qs = np.concatenate(SeenFeatureMap.seen)
    offsets = samples.step_offsets(dataset)
    lasts = offsets[1:] - 1
    extra = np.isin(held.step, lasts)
    # the other steps' samples are unchanged
    keep = ~np.isin(plain.step, lasts)
    np.testing.assert_array_equal(held.y[~extra], plain.y[keep])
    np.testing.assert_array_equal(held.weight[~extra], plain.weight[keep])
    features = FeatureMap(dataset.definition, robot)
    for i, demo in enumerate(dataset.demos):
        last = offsets[i + 1] - 1
        mine = np.flatnonzero(held.step == last)
        before = np.sum(plain.step == last)
        assert held.kept_per_step[last] == len(mine) and COUNT // 2 <= len(mine) - before <= COUNT
        around_end = mine[before:]  # stable order: the step's own samples first, then the hold's
        distances = np.linalg.norm(qs[around_end] - demo.q[-1], axis=1)
        np.testing.assert_allclose(held.weight[around_end], distances, rtol=0, atol=1e-12)
        np.testing.assert_allclose(
            held.y[around_end],
            features.batch(qs[around_end], demo.object_poses[-1]),
            rtol=0,
            atol=1e-12,
        )
        # centred on q_{T-1}: the mean offset is small against sigma
        assert np.all(np.abs(np.mean(qs[around_end] - demo.q[-1], axis=0)) < SIGMA)
        assert np.all(qs[around_end] >= robot.lower) and np.all(qs[around_end] <= robot.upper)
