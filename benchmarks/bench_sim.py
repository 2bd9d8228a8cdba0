"""Simulator benchmarks.

sim_lockstep_rtf: real-time factor of the simulator node in lockstep mode, through ROS: the node
  (spun by a SingleThreadedExecutor, as `ros2 run` does) and a trivial commander, which answers each
  /joint_states with the same positions as its /joint_command, in one process. The commander waits
  on /joint_states with tric_sim.ros.topic_poller.TopicPoller, as the teacher and controller nodes
  do. Median of three runs of 4 s of wall time each.
sim_lockstep_period_us: the median wall time of one lockstep period (state -> command -> step).
sim_physics_period_us: one control period of raw stepping (3 physics steps + distance check), no
ROS.
sim_ros_round_trip_us: the floor of a lockstep period's ROS part: one JointState each way between
  two threads of one process, each waiting with a TopicPoller, nothing else (no physics, no
  /clock or /object_poses); the median of ROUND_TRIPS. sim_ros_round_trip_header_us: the same with
  the emptiest message, a std_msgs/Header, each way: what delivery costs whatever the content.
"""

import statistics
import threading
import time

import rclpy
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from sensor_msgs.msg import JointState
from std_msgs.msg import Header

from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.ros.topic_poller import TopicPoller
from tric_sim.simulator_node import SimulatorNode
from tric_sim.world import situations
from tric_sim.world.robot_model import RobotModel

RUN_S = 4.0
ROUND_TRIPS = 2000


def lockstep_rtf() -> float:
    context = Context()
    rclpy.init(context=context)
    simulator = SimulatorNode(
        context=context, parameter_overrides=[Parameter("mode", value="lockstep")]
    )
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(simulator)
    threading.Thread(target=executor.spin, daemon=True).start()
    commander = Node("trivial_commander", context=context)
    publisher = commander.create_publisher(JointState, "/joint_command", 10)
    states = TopicPoller(
        context, "trivial_commander_poller", {"state": (JointState, "/joint_states", 10)}
    )
    stop = threading.Event()

    def answer():
        while not stop.is_set():
            for state in states.poll(0.05)["state"]:
                command = JointState(name=state.name, position=state.position)
                command.header.stamp = state.header.stamp
                publisher.publish(command)

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    time.sleep(1.0)  # discovery and warm-up
    start_periods, start = simulator.world.periods, time.perf_counter()
    time.sleep(RUN_S)
    periods, wall = simulator.world.periods - start_periods, time.perf_counter() - start
    stop.set()
    thread.join()
    states.destroy()
    executor.shutdown()
    simulator.destroy_node()
    commander.destroy_node()
    context.try_shutdown()
    return periods * simulator.world.control_period / wall


def physics_period_us() -> float:
    robot = RobotModel()
    world = PhysicsWorld(robot)
    world.reset(situations.dataset("sphere_test")[0])
    for _ in range(50):
        world.step()
    start = time.perf_counter()
    for _ in range(1000):
        world.step()
    elapsed = time.perf_counter() - start
    world.close()
    return elapsed / 1000 * 1e6


def ros_round_trip_us(message_type=JointState) -> float:
    """The median round trip, us, of a message of message_type (JointState: 20 named joints,
    answered by a command naming them; Header: answered by itself)."""
    context = Context()
    rclpy.init(context=context)
    node = Node("round_trip", context=context)
    state_pub = node.create_publisher(message_type, "/round_trip_state", 10)
    command_pub = node.create_publisher(message_type, "/round_trip_command", 10)
    states = TopicPoller(
        context, "round_trip_states", {"s": (message_type, "/round_trip_state", 10)}
    )
    commands = TopicPoller(
        context, "round_trip_commands", {"c": (message_type, "/round_trip_command", 10)}
    )
    names = [f"joint_{k}" for k in range(20)]
    stop = threading.Event()

    def message(k: int):
        if message_type is Header:
            return Header(frame_id="state")
        return JointState(name=names, position=[float(k)] * len(names))

    def answer():
        while not stop.is_set():
            for state in states.poll(0.05)["s"]:
                if message_type is Header:
                    command_pub.publish(state)
                else:
                    command_pub.publish(JointState(name=state.name, position=state.position))

    thread = threading.Thread(target=answer, daemon=True)
    thread.start()
    time.sleep(1.0)  # discovery
    trips = []
    for k in range(ROUND_TRIPS):
        start = time.perf_counter()
        state_pub.publish(message(k))
        while not commands.poll(1.0)["c"]:
            pass
        trips.append(time.perf_counter() - start)
    stop.set()
    thread.join()
    states.destroy()
    commands.destroy()
    node.destroy_node()
    context.try_shutdown()
    return statistics.median(trips) * 1e6


def run() -> dict:
    rtfs = [lockstep_rtf() for _ in range(3)]
    rtf = statistics.median(rtfs)
    return {
        "sim_lockstep_rtf": round(rtf, 1),
        "sim_lockstep_rtf_runs": [round(r, 1) for r in rtfs],
        "sim_lockstep_period_us": round(10_000 / rtf),
        "sim_physics_period_us": round(physics_period_us()),
        "sim_ros_round_trip_us": round(ros_round_trip_us()),
        "sim_ros_round_trip_header_us": round(ros_round_trip_us(Header)),
    }
