"""The controller node's lockstep mode (with the simulator in lockstep): the simulator publishes
the state of period t (stamped t) and waits; the controller answers that /joint_states message with
exactly one /joint_command stamped t; the simulator then simulates one period and publishes the
state t + period. The control loop runs in a thread of its own that waits on the topics directly
(tric_sim.ros.topic_poller), one episode at a time."""

import threading
import time

from tric_control.loops.episode import POLL_S, Episode
from tric_sim.ros.graph import STATE_QOS, Canceled
from tric_sim.ros.topic_poller import StateStream, run_in_thread


class LockstepLoop:
    """Runs the episodes of node (a tric_control.controller_node.ControllerNode) in lockstep: each
    new joint state answered with one command by node._tick."""

    def __init__(self, node):
        self.node = node
        self.stream = StateStream(
            node.context, "controller_state_stream", node.robot.joint_names, STATE_QOS
        )
        self._control_thread = None

    async def run(self, episode: Episode):
        """The episode run to its end in the control thread: (outcome, message)."""
        try:
            return await run_in_thread(self.node, self._drive, episode)
        except Canceled:
            return "canceled", "canceled"
        except RuntimeError as error:
            return "failed", str(error)
        except Exception as error:  # a bug: still an answer, not a traceback
            self.node.get_logger().error(f"episode failed: {error!r}")
            return "failed", f"internal error: {type(error).__name__}: {error}"

    def stop(self) -> None:
        """Wait (5 s at most) for the control thread to end; the node has set its stop event."""
        thread = self._control_thread
        if thread is not None and thread is not threading.current_thread():
            thread.join(timeout=5.0)

    def destroy(self) -> None:
        self.stream.destroy()

    def _drive(self, episode: Episode):
        """The lockstep control loop (in its own thread): answer each new state with one command.
        Returns (outcome, message); raises Canceled or RuntimeError."""
        node = self.node
        self._control_thread = threading.current_thread()
        try:
            last = -1
            while True:
                stamp, q = self._next_state(episode, last)
                if last >= 0 and stamp - last != node.period_ns and episode.steps == 1:
                    node.get_logger().warning(
                        f"joint states come every {(stamp - last) / 1e6:g} ms of simulated time, "
                        f"but control_rate_hz sets a period of {node.period * 1e3:g} ms"
                    )
                last = stamp
                poses = self.stream.poses
                missing = episode.runner.missing(poses)
                if missing:
                    raise RuntimeError(
                        f"no pose of {', '.join(missing)} on /object_poses: is the simulator "
                        "running?"
                    )
                outcome = node._tick(episode, stamp, q, poses, stamp)
                if outcome:
                    return outcome
        finally:
            self._control_thread = None

    def _next_state(self, episode: Episode, after_ns: int):
        """(stamp_ns, q) of the next joint state, waiting up to state_timeout_s; raises Canceled or
        RuntimeError (no states, a new scene, shutdown)."""
        node = self.node
        deadline = time.monotonic() + node.state_timeout
        while True:
            if node._stop.is_set():
                raise RuntimeError("the controller is shutting down")
            if episode.goal_handle.is_cancel_requested:
                raise Canceled()
            if node.scene is not episode.scene:
                raise RuntimeError("the scene was reset during the episode")
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                raise RuntimeError(
                    f"no joint states for {node.state_timeout:g} s: is the simulator running?"
                )
            state = self.stream.next_state(min(remaining, POLL_S), after_ns=after_ns)
            if state is not None:
                return state
