"""ROS plumbing shared by every node and in-process tool: the QoS profiles of the topics, the
exception a canceled goal raises, run_node (the body of every node executable's main()) and the
in-process graph the tools run their nodes in, on a private DDS domain."""

import os
import signal
import sys
import threading
import time

import rclpy
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

from tric_sim.tools.interrupts import end_at_once, end_commands_on_signals

#: The periodic state topics (/joint_states, /object_poses, /clock, /joint_command, ~/status):
#: reliable, shallow.
STATE_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
#: /episode: reliable, deep enough for the events of one episode.
EVENT_QOS = QoSProfile(depth=20, reliability=ReliabilityPolicy.RELIABLE)
#: /situation, /robot_description, /scene_markers: latched for late joiners.
LATCHED_QOS = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)


class Canceled(Exception):
    """The goal was canceled while a node drove the robot (an episode, a demonstration)."""


#: Wall seconds a node has, after SIGINT or SIGTERM, to leave the ROS graph in order (its executor
#: stopped, the node destroyed, the context shut down) before its process ends at once: the node
#: ends within 2 s either way.
NODE_CLEANUP_S = 1.5


def run_node(node_class, prog: str, args=None) -> int:
    """Run node_class() under rclpy as `ros2 run` runs it; prog names the executable in its lines.
    A node that refuses its parameters (ValueError) ends the process with its message on one line
    and exit status 2; an external shutdown of the context ends it with status 0.

    SIGINT or SIGTERM ends the process (run_node does not return) with one line and exit status
    130 or 143, as a tool ends (tric_sim.tools.interrupts.end_at_once): while the node is being
    built, at once; once it spins, after leaving the ROS graph in order (else other processes would
    see it until its DDS lease ends), or at once when that takes more than NODE_CLEANUP_S or a
    second signal comes. rclpy's own handlers, which shut the context down under the node's running
    threads, are not installed: the executor spins in a thread of its own while the main thread,
    where signal handlers run, waits."""
    previous = {signum: signal.getsignal(signum) for signum in (signal.SIGINT, signal.SIGTERM)}
    end_commands_on_signals(prog)
    try:
        rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
        try:
            node = node_class()
        except ValueError as error:
            print(f"{prog}: {error}", file=sys.stderr)
            rclpy.try_shutdown()
            return 2
        return _spin_until_signal(node, prog)
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def _spin_until_signal(node, prog: str) -> int:
    """Spin node until SIGINT or SIGTERM (see run_node) or an external shutdown (status 0)."""
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    ended, failures, stopping = threading.Event(), [], {}

    def on_signal(signum, frame):
        if stopping:  # a second signal: no more waiting
            end_at_once(prog, stopping["signum"])
        stopping["signum"] = signum
        stopping["deadline"] = threading.Timer(NODE_CLEANUP_S, end_at_once, (prog, signum))
        stopping["deadline"].daemon = True
        stopping["deadline"].start()
        ended.set()

    def spin():
        try:
            executor.spin()
        except ExternalShutdownException:
            pass
        except BaseException as error:  # raised again in the main thread
            failures.append(error)
        finally:
            ended.set()

    signal.signal(signal.SIGINT, on_signal)
    signal.signal(signal.SIGTERM, on_signal)
    spinner = threading.Thread(target=spin, name=f"{prog}_executor")
    spinner.start()
    ended.wait()
    executor.shutdown()
    spinner.join()
    node.destroy_node()
    rclpy.try_shutdown()
    if stopping:  # out of the graph: the interpreter's own teardown (seconds with torch) skipped
        stopping["deadline"].cancel()
        end_at_once(prog, stopping["signum"])
    if failures:
        raise failures[0]
    return 0


class InProcessGraph:
    """Nodes spun by one SingleThreadedExecutor in a background thread, on a context of their own.

    domain_id: the DDS domain of the context (None: the environment's ROS_DOMAIN_ID). Discovery is
    limited to this machine unless ROS_AUTOMATIC_DISCOVERY_RANGE says otherwise."""

    def __init__(self, domain_id: int = None):
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        self.context = Context()
        # The tool owns SIGINT and SIGTERM (tric_sim.tools.interrupts): its main thread ends the run
        # and closes this graph; rclpy's own handlers would shut the context under the running
        # nodes.
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
