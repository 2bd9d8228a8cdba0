"""The teacher node demonstrates on the simulator node, in-process and in lockstep."""

from action_msgs.msg import GoalStatus
from rclpy.node import Node
from rclpy.parameter import Parameter

from conftest import run_action, run_periods, wait_for
from tric_msgs.action import Demonstrate
from tric_msgs.msg import EpisodeEvent
from tric_sim import teacher_node
from tric_sim.ros import messages
from tric_sim.simulator_node import SimulatorNode
from tric_sim.teacher_node import TeacherNode
from tric_sim.world import situations


def start(ros_context, spin):
    simulator = SimulatorNode(
        context=ros_context, parameter_overrides=[Parameter("mode", value="lockstep")]
    )
    teacher = TeacherNode(context=ros_context)
    client = Node("test_client", context=ros_context)
    events = []
    client.create_subscription(EpisodeEvent, "/episode", events.append, 20)
    spin(simulator, teacher, client)
    return client, events


def demonstrate(client, situation):
    goal = Demonstrate.Goal(situation=messages.situation_to_msg(situation))
    return run_action(client, Demonstrate, "/teacher/demonstrate", goal)


def test_grasps_a_grid_sphere_and_a_random_test_sphere(ros_context, spin):
    client, events = start(ros_context, spin)
    for situation in (situations.sphere_grid()[4], situations.dataset("sphere_test")[5]):
        status, result, feedback = demonstrate(client, situation)
        assert status == GoalStatus.STATUS_SUCCEEDED, result.message
        assert result.metrics.grasp_cost < 0.25 and result.metrics.lift_passed
        assert not result.metrics.collided
        assert abs(result.duration_s - 5.0) < 0.02 and result.steps == 500
        assert {f.phase for f in feedback} >= {"reach", "hold"}
    wait_for(lambda: len(events) == 6, what="three events per episode")
    assert [e.event for e in events[:3]] == [
        EpisodeEvent.START,
        EpisodeEvent.END,
        EpisodeEvent.OUTCOME,
    ]
    assert events[0].situation.name == situations.sphere_grid()[4].name
    assert events[2].metrics.lift_tested


def test_opens_a_box(ros_context, spin):
    client, _ = start(ros_context, spin)
    status, result, _ = demonstrate(client, situations.dataset("box_test")[0])
    assert status == GoalStatus.STATUS_SUCCEEDED, result.message
    assert result.metrics.lid_angle > 0.3 and result.metrics.success
    assert result.planning_time_s > 0


def test_bad_situation_is_refused(ros_context, spin):
    client, events = start(ros_context, spin)
    bad = messages.situation_to_msg(situations.sphere_grid()[0])
    bad.object_kind = "teapot"
    status, result, _ = run_action(
        client, Demonstrate, "/teacher/demonstrate", Demonstrate.Goal(situation=bad)
    )
    assert status == GoalStatus.STATUS_ABORTED and "teapot" in result.message
    run_periods(client)
    assert not events


def test_a_demonstration_too_long_or_not_finite_is_refused(ros_context, spin):
    """A duration of inf (tric-record --duration inf) failed inside the teacher with an
    OverflowError; past MAX_DURATION a demonstration recorded without bound."""
    client, events = start(ros_context, spin)
    situation = messages.situation_to_msg(situations.sphere_grid()[0])
    for duration in (float("inf"), float("nan"), 1e9):
        goal = Demonstrate.Goal(situation=situation, duration=duration)
        status, result, _ = run_action(client, Demonstrate, "/teacher/demonstrate", goal)
        assert status == GoalStatus.STATUS_ABORTED
        assert result.message.startswith("duration must be in [0, 120] simulated s"), result.message
    run_periods(client)
    assert not events


def test_a_teacher_without_a_simulator_waits_for_it_then_aborts_naming_it(
    ros_context, spin, monkeypatch
):
    """The simulator's services are waited for (a graph that just started may not have found them
    yet), SERVICE_WAIT_S at most (0.3 s here), then the goal is aborted naming the service."""
    monkeypatch.setattr(teacher_node, "SERVICE_WAIT_S", 0.3)
    client = Node("test_client", context=ros_context)
    spin(TeacherNode(context=ros_context), client)
    status, result, _ = demonstrate(client, situations.sphere_grid()[4])
    assert status == GoalStatus.STATUS_ABORTED and not result.success
    assert result.message == (
        "service /simulator/reset_scene is not available after 0.3 s: is the simulator running?"
    )
