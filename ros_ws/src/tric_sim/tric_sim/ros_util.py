"""ROS plumbing shared by every node and in-process tool: the QoS profiles of the topics, the
exception a canceled goal raises, run_node (the body of every node executable's main()) and the
in-process graph the tools run their nodes in, on a private DDS domain."""

import os
import sys
import threading
import time

import rclpy
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

#: The periodic state topics (/joint_states, /object_poses, /clock, /joint_command, ~/status):
#: reliable, shallow.
STATE_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
#: /episode: reliable, deep enough for the events of one episode.
EVENT_QOS = QoSProfile(depth=20, reliability=ReliabilityPolicy.RELIABLE)
#: /situation, /robot_description, /scene_markers: latched for late joiners.
LATCHED_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class Canceled(Exception):
    """The goal was canceled while a node drove the robot (an episode, a demonstration)."""


def run_node(node_class, prog: str, args=None) -> int:
    """Run node_class() under rclpy as `ros2 run` runs it; prog names the executable in the error
    message. Spins the node until Ctrl-C (also one while it is being built) or an external
    shutdown, then destroys it. A node that refuses its parameters (ValueError) ends the process
    with its message on one line and exit status 2; otherwise the status is 0. The executor is
    made before the node, whose constructor announces it is ready: a Ctrl-C right after that line
    finds the executor whole (one interrupted in its own constructor leaves rclpy printing a
    traceback when it is collected)."""
    rclpy.init(args=args)
    try:
        executor = SingleThreadedExecutor()
        node = node_class()
    except ValueError as error:
        print(f"{prog}: {error}", file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    except KeyboardInterrupt:  # Ctrl-C while the node was being built
        rclpy.try_shutdown()
        return 0
    except Exception:
        if not rclpy.ok():  # Ctrl-C while the node was being built: rclpy shut its context down
            return 0
        raise
    try:
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0


class InProcessGraph:
    """Nodes spun by one SingleThreadedExecutor in a background thread, on a context of their own.

    domain_id: the DDS domain of the context (None: the environment's ROS_DOMAIN_ID). Discovery is
    limited to this machine unless ROS_AUTOMATIC_DISCOVERY_RANGE says otherwise."""

    def __init__(self, domain_id: int = None):
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        self.context = Context()
        # The tool owns SIGINT and SIGTERM (tric_sim.interrupts): its main thread ends the run and
        # closes this graph; rclpy's own handlers would shut the context under the running nodes.
        rclpy.init(
            context=self.context,
            domain_id=domain_id,
            signal_handler_options=SignalHandlerOptions.NO,
        )
        self.executor = SingleThreadedExecutor(context=self.context)
        self.nodes = []
        self._thread = None

    def add(self, node):
        self.nodes.append(node)
        self.executor.add_node(node)
        return node

    def start(self):
        self._thread = threading.Thread(target=self.executor.spin, daemon=True)
        self._thread.start()

    def close(self):
        """Stop spinning (waiting for the executor thread), then destroy the nodes and the
        context."""
        self.executor.shutdown()
        if self._thread is not None:
            self._thread.join(timeout=10.0)
        for node in reversed(self.nodes):
            node.destroy_node()
        self.context.try_shutdown()


def wait(future, timeout: float, what: str):
    """future's result once it is done, polled every 5 ms; TimeoutError after timeout s (what
    names the awaited thing in the message)."""
    deadline = time.monotonic() + timeout
    while not future.done():
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.005)
    return future.result()
