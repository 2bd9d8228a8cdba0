"""Perturbations in the core: a push and a moved target change the simulated state as specified,
within the joint limits; impossible ones are refused before an episode; situations carry them
through files and messages; the trials are reproducible."""

import dataclasses

import numpy as np
import pytest

from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.ros import messages
from tric_sim.world import situations as S
from tric_sim.world.perturbation_trials import Trial, parse_trial
from tric_sim.world.perturbations import SETTLE_S, Perturbation, min_steps_for
from tric_sim.world.robot_model import RobotModel
from tric_sim.world.scene_check import check_scene
from tric_sim.world.situation import Situation
from tric_sim.world.situation_files import load_situations, save_situations


@pytest.fixture(scope="module")
def robot():
    return RobotModel()


@pytest.fixture
def world(robot):
    w = PhysicsWorld(robot)
    yield w
    w.close()


def push(robot, joint: int, size: float, start_s=0.2, duration_s=0.1) -> Perturbation:
    offset = np.zeros(robot.n_joints)
    offset[joint] = size
    return Perturbation("push", start_s, tuple(offset), duration_s)


def run(world, situation, seconds: float) -> np.ndarray:
    """Reset to situation and hold the initial targets for seconds; the final joint positions."""
    world.reset(situation)
    for _ in range(int(round(seconds / world.control_period))):
        world.step()
    return world.joint_state()[0]


def test_the_share_of_an_offset_is_spread_over_its_duration():
    spread = Perturbation("move_target", 0.5, (0.1, 0.0, 0.0), 0.2)
    shares = [spread.share(k * 0.01, (k + 1) * 0.01) for k in range(100)]
    assert sum(shares) == pytest.approx(1.0)
    assert all(s == 0 for s in shares[:50]) and all(s == 0 for s in shares[70:])
    assert shares[55] == pytest.approx(0.05)
    jump = Perturbation("move_target", 0.505, (0.1, 0.0, 0.0))
    assert [k for k in range(100) if jump.share(k * 0.01, (k + 1) * 0.01)] == [50]


def test_a_push_moves_the_joint_by_its_offset_and_the_others_hold(world, robot):
    sphere = S.dataset("sphere_test")[0]
    joint = int(robot.arm_indices[1])
    still = run(world, sphere, 1.0)
    pushed = run(world, dataclasses.replace(sphere, perturbations=(push(robot, joint, 0.3),)), 1.0)
    moved = pushed - still
    assert moved[joint] == pytest.approx(0.3, abs=0.02)
    others = np.delete(moved[robot.arm_indices], 1)
    assert np.max(np.abs(others)) < 0.02
    assert np.allclose(world.targets[joint], still[joint] + 0.3, atol=0.02)


def test_a_push_past_a_limit_stops_the_joint_at_its_limit(world, robot):
    sphere = S.dataset("sphere_test")[0]
    joint = int(robot.arm_indices[5])  # 0.55 rad below its upper limit at home
    room = robot.upper[joint] - robot.home[joint]
    shove = dataclasses.replace(sphere, perturbations=(push(robot, joint, room + 0.5),))
    q = run(world, shove, 1.0)
    assert q[joint] == pytest.approx(robot.upper[joint], abs=0.01)
    assert world.stops.max_overshoot <= 0.01


def test_a_moved_target_moves_the_object_as_specified(world):
    sphere = S.dataset("sphere_test")[0]
    start = np.array(sphere.object_position)
    jump = Perturbation("move_target", 0.1, (0.05, -0.02, 0.0))
    drift = Perturbation("move_target", 0.5, (0.0, 0.0, 0.04), 1.0)
    world.reset(dataclasses.replace(sphere, perturbations=(jump, drift)))
    for _ in range(50):  # 0.5 s: the jump is done, the drift not begun
        world.step()
    position = np.array(world.object_poses()["object"][0])
    assert np.allclose(position, start + (0.05, -0.02, 0.0), atol=2e-3)
    for _ in range(50):  # half the drift
        world.step()
    position = np.array(world.object_poses()["object"][0])
    assert np.allclose(position, start + (0.05, -0.02, 0.02), atol=3e-3)


def test_impossible_perturbations_are_refused_before_the_episode(robot):
    sphere, box = S.dataset("sphere_test")[0], S.dataset("box_test")[0]
    n = robot.n_joints
    cases = [
        (sphere, Perturbation("shove", 0.1, (0.0,) * n), "unknown perturbation kind 'shove'"),
        (sphere, Perturbation("push", 0.1, (0.1, 0.2)), "offset must be 14 finite numbers"),
        (sphere, Perturbation("push", 0.1, (float("nan"),) * n), "must be 14 finite numbers"),
        (sphere, Perturbation("push", -1.0, (0.0,) * n), "start_s must be in [0, 600] s"),
        (sphere, Perturbation("push", 0.1, (0.0,) * n, float("inf")), "duration_s must be in"),
        (sphere, Perturbation("push", 0.1, (1.0,) * n), "is over the 2 rad a push may be"),
        (box, Perturbation("move_target", 1.0, (0.05, 0.0, 0.0)), "has no grasp target to move"),
        (sphere, Perturbation("move_target", 1.0, (0.0, 0.6, 0.0)), "over the 0.5 m a move"),
        (
            sphere,
            Perturbation("move_target", 1.0, (0.0, 0.0, -0.19)),
            "its perturbations move the sphere 2.2 cm into the table",
        ),
        (
            sphere,
            Perturbation("move_target", 1.0, (0.0, 0.0, -0.3)),
            "the object moved by its perturbations to (0.6047, 0.2252, -0.0923) is outside the "
            "workspace",
        ),
    ]
    for situation, perturbation, message in cases:
        perturbed = dataclasses.replace(situation, perturbations=(perturbation,))
        with pytest.raises(ValueError, match="perturbation|perturbations") as error:
            check_scene(perturbed.validate(n), robot)
        assert message in str(error.value)
    with pytest.raises(ValueError, match="not KIND:SIZE"):
        parse_trial("kick:0.2")
    with pytest.raises(ValueError, match="must be numbers"):
        parse_trial("push:big")
    with pytest.raises(ValueError, match="no start 9 rad from its own"):
        Trial("start", 9.0).apply(sphere, robot)  # past every joint range


def test_the_simulator_schedules_only_what_is_yet_to_come(world, robot):
    sphere = S.dataset("sphere_test")[0]
    world.reset(sphere)
    for _ in range(30):
        world.step()
    with pytest.raises(ValueError, match="starts at 0.1 s, but the episode is at 0.3 s"):
        world.schedule([Perturbation("move_target", 0.1, (0.05, 0.0, 0.0))])
    with pytest.raises(ValueError, match="into the table"):
        world.schedule([Perturbation("move_target", 0.5, (0.0, 0.0, -0.19))])
    assert world.situation == sphere  # nothing scheduled
    world.schedule([Perturbation("move_target", 0.5, (0.05, 0.0, 0.0))])
    for _ in range(30):
        world.step()
    moved = np.array(world.object_poses()["object"][0]) - sphere.object_position
    assert np.allclose(moved, (0.05, 0.0, 0.0), atol=2e-3)


def test_situations_carry_perturbations_through_files_and_messages(tmp_path, robot):
    sphere = S.dataset("sphere_test")[2]
    perturbed = Trial("drift", 0.02).apply(Trial("push", 0.2).apply(sphere, robot), robot)
    assert [p.kind for p in perturbed.perturbations] == ["push", "move_target"]
    assert Situation.from_dict(perturbed.to_dict()) == perturbed
    assert messages.situation_from_msg(messages.situation_to_msg(perturbed)) == perturbed
    save_situations(tmp_path / "perturbed.yaml", [perturbed])
    assert load_situations(tmp_path / "perturbed.yaml", robot) == [perturbed]
    entry = perturbed.to_dict()
    entry["perturbations"][0]["force"] = 3.0
    with pytest.raises(ValueError, match="bad perturbation entry"):
        Situation.from_dict(entry)


def test_trials_are_reproducible_and_grow_along_one_direction(robot):
    sphere = S.dataset("sphere_test")[4]
    small, large = (Trial("push", size).apply(sphere, robot) for size in (0.1, 0.4))
    assert Trial("push", 0.1).apply(sphere, robot) == small
    small_offset = np.array(small.perturbations[0].offset)
    assert np.allclose(np.array(large.perturbations[0].offset), 4 * small_offset)
    assert np.linalg.norm(small_offset) == pytest.approx(0.1)
    assert not np.any(small_offset[robot.hand_indices])
    jump = Trial("jump", 0.05, at_s=1.5).apply(sphere, robot)
    assert jump.name == "sphere_test_04_jump0.05@1.5" and jump.perturbations[0].start_s == 1.5
    assert np.linalg.norm(jump.perturbations[0].offset) == pytest.approx(0.05)
    assert jump.perturbations[0].offset[2] == 0.0  # sideways
    start = Trial("start", 0.2).apply(sphere, robot)
    q0 = np.array(start.initial_joint_positions)
    assert np.linalg.norm(q0 - robot.home) == pytest.approx(0.2)
    assert np.all(q0 >= robot.lower) and np.all(q0 <= robot.upper)
    assert Trial("jump", 0.0).apply(sphere, robot).perturbations == ()
    [jolt] = Trial("jolt", 0.4, at_s=7.5).apply(sphere, robot).perturbations
    assert jolt.kind == "push" and jolt.start_s == 7.5 and jolt.duration_s == 0.0
    assert np.linalg.norm(jolt.offset) == pytest.approx(0.4)
    assert parse_trial("jolt:0.4@7.5") == Trial("jolt", 0.4, 7.5)


def test_an_episode_runs_past_its_last_perturbation_by_the_settling_time(robot):
    """min_steps_for: none for no perturbation; else the ticks until the last one has acted (a
    push from 1.0 s over 0.1 s, a jump at 2.0 s) and SETTLE_S more, at a 10 ms period."""
    assert min_steps_for((), 0.01) == 0
    assert min_steps_for((push(robot, 0, 0.1, 1.0, 0.1),), 0.01) == round(110 + SETTLE_S * 100) + 1
    jump = Perturbation("move_target", 2.0, (0.05, 0.0, 0.0))
    assert min_steps_for((push(robot, 0, 0.1, 1.0, 0.1), jump), 0.01) == 251
