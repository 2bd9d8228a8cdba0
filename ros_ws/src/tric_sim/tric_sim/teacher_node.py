"""The teacher node: demonstrates situations on the simulator (action ~/demonstrate).

For each goal it resets the simulator's scene to the goal's situation (/simulator/reset_scene),
publishes EpisodeEvent START on /episode, drives the robot with the task's teacher (the phased grasp
controller, or the box-opening planner) by answering every /joint_states with a /joint_command of
the same stamp, publishes END, asks the simulator for the hidden metrics (/simulator/evaluate_task,
with the lift test for grasps), publishes them as OUTCOME and returns them. One goal at a time;
others are rejected while one runs. A goal's duration must be in [0, MAX_DURATION] simulated s
(tric_sim.world.durations; 0: the task's default), or the goal is aborted saying so.
"""

import sys
import threading

from rclpy.action import ActionServer, CancelResponse, GoalResponse
from rclpy.node import Node
from sensor_msgs.msg import JointState

from tric_msgs.action import Demonstrate
from tric_msgs.msg import EpisodeEvent
from tric_msgs.srv import EvaluateTask, ResetScene
from tric_sim.ros import messages
from tric_sim.ros.graph import EVENT_QOS, STATE_QOS, Canceled, run_node
from tric_sim.ros.parameters import POSITIVE, declare, declare_robot
from tric_sim.ros.topic_poller import StateStream, command_msg, run_in_thread
from tric_sim.teachers import make_teacher
from tric_sim.world.durations import DEFAULT_DURATION, MAX_DURATION

#: How long a goal waits for the simulator's services to be discovered before it is aborted, s.
SERVICE_WAIT_S = 10.0


class TeacherNode(Node):
    """Serves ~/demonstrate (tric_msgs/action/Demonstrate); see the module docstring."""

    def __init__(self, **kwargs):
        super().__init__("teacher", **kwargs)
        simulator = declare(self, "simulator", "/simulator", "the simulator node's name")
        self.state_timeout = declare(
            self,
            "state_timeout_s",
            10.0,
            "wall seconds without joint states before a goal aborts",
            POSITIVE,
        )
        self.robot = declare_robot(self)
        self.command_pub = self.create_publisher(JointState, "/joint_command", STATE_QOS)
        self.episode_pub = self.create_publisher(EpisodeEvent, "/episode", EVENT_QOS)
        self.reset_client = self.create_client(ResetScene, f"{simulator}/reset_scene")
        self.evaluate_client = self.create_client(EvaluateTask, f"{simulator}/evaluate_task")
        self.stream = StateStream(
            self.context, "teacher_state_stream", self.robot.joint_names, STATE_QOS
        )
        self._busy = threading.Lock()
        self._server = ActionServer(
            self,
            Demonstrate,
            "~/demonstrate",
            execute_callback=self._execute,
            goal_callback=self._on_goal,
            cancel_callback=lambda _: CancelResponse.ACCEPT,
        )
        self.get_logger().info(f"ready to demonstrate on ~/demonstrate with {simulator}")

    def destroy_node(self):
        self._server.destroy()
        self.stream.destroy()
        return super().destroy_node()

    def _on_goal(self, goal):
        if not self._busy.acquire(blocking=False):
            self.get_logger().warning("demonstration refused: another one is running")
            return GoalResponse.REJECT
        self._busy.release()
        return GoalResponse.ACCEPT

    async def _execute(self, goal_handle):
        with self._busy:
            return await self._demonstrate(goal_handle)

    async def _demonstrate(self, goal_handle):
        goal = goal_handle.request
        result = Demonstrate.Result()
        try:
            situation = messages.situation_from_msg(goal.situation, self.robot.n_joints)
        except ValueError as error:
            return self._abort(goal_handle, result, f"bad situation: {error}")
        for client in (self.reset_client, self.evaluate_client):
            # a graph that just started may not have discovered the simulator yet: a loaded
            # machine took more than the first goal (tric-experiments' table2 lost every
            # demonstration to it once)
            if not client.wait_for_service(timeout_sec=SERVICE_WAIT_S):
                return self._abort(
                    goal_handle,
                    result,
                    f"service {client.srv_name} is not available after {SERVICE_WAIT_S:g} s: is "
                    "the simulator running?",
                )
        episode_id = goal.episode_id or situation.name
        if not 0.0 <= goal.duration <= MAX_DURATION:  # NaN too
            return self._abort(
                goal_handle,
                result,
                f"duration must be in [0, {MAX_DURATION:g}] simulated s (0: the task's default), "
                f"got {goal.duration}",
            )
        duration = goal.duration if goal.duration > 0 else DEFAULT_DURATION[situation.task]
        reset = await self.reset_client.call_async(ResetScene.Request(situation=goal.situation))
        if not reset.success:
            return self._abort(goal_handle, result, reset.message)
        reset_ns = messages.time_ns(reset.joint_state.header.stamp)
        q_start = messages.joint_positions_from_msg(reset.joint_state, self.robot.joint_names)
        self.get_logger().info(f"demonstrating '{episode_id}' ({situation.task}, {duration:g} s)")
        try:
            steps, start_ns, end_ns, planning = await run_in_thread(
                self, self._drive, goal_handle, situation, episode_id, q_start, reset_ns, duration
            )
        except Canceled:
            self._event(EpisodeEvent.ABORT, episode_id, reset_ns)
            goal_handle.canceled()
            result.message = "canceled"
            return result
        except RuntimeError as error:
            self._event(EpisodeEvent.ABORT, episode_id, reset_ns)
            return self._abort(goal_handle, result, str(error))
        # the teacher cannot handle this situation: an answer, not a traceback
        except Exception as error:
            self._event(EpisodeEvent.ABORT, episode_id, reset_ns)
            return self._abort(
                goal_handle, result, f"the teacher failed: {type(error).__name__}: {error}"
            )
        self._event(EpisodeEvent.END, episode_id, end_ns)
        evaluation = await self.evaluate_client.call_async(
            EvaluateTask.Request(run_lift_test=situation.task == "grasp")
        )
        self._event(EpisodeEvent.OUTCOME, episode_id, end_ns, metrics=evaluation.metrics)
        result.success, result.metrics = evaluation.success, evaluation.metrics
        result.message = (
            f"demonstrated '{episode_id}'" if evaluation.success else evaluation.message
        )
        result.steps, result.duration_s = steps, (end_ns - start_ns) / 1e9
        result.planning_time_s = planning
        goal_handle.succeed()
        return result

    def _drive(self, goal_handle, situation, episode_id, q_start, reset_ns, duration):
        """The control loop (in its own thread): answer each state with the teacher's command."""
        teacher = make_teacher(self.robot, situation, q_start)
        if teacher.planning_time_s:
            self.get_logger().info(f"plan ready in {teacher.planning_time_s:.2f} s")
        duration_ns = int(round(duration * 1e9))
        start_ns, steps, last = None, 0, reset_ns - 1
        while True:
            if goal_handle.is_cancel_requested:
                raise Canceled()
            state = self.stream.next_state(self.state_timeout, after_ns=last)
            if state is None:
                raise RuntimeError(
                    f"no joint states for {self.state_timeout:g} s: is the simulator running?"
                )
            last, q = state
            if start_ns is None:
                start_ns = last
                self._event(EpisodeEvent.START, episode_id, start_ns, situation=situation)
            elapsed_ns = last - start_ns
            if elapsed_ns >= duration_ns:
                return steps, start_ns, last, teacher.planning_time_s
            if "object" not in self.stream.poses:
                raise RuntimeError("no /object_poses with an 'object': is the simulator running?")
            target = teacher.command(elapsed_ns / 1e9, q, self.stream.poses)
            self.command_pub.publish(command_msg(self.robot.joint_names, target, last))
            steps += 1
            if steps % 25 == 0:
                goal_handle.publish_feedback(
                    Demonstrate.Feedback(
                        phase=teacher.phase, step=steps, fraction=min(elapsed_ns / duration_ns, 1.0)
                    )
                )

    def _event(self, kind, episode_id, stamp_ns, situation=None, metrics=None):
        msg = EpisodeEvent(event=kind, episode_id=episode_id, source="teacher")
        msg.header.stamp = messages.time_msg(stamp_ns)
        if situation is not None:
            msg.situation = messages.situation_to_msg(situation)
        if metrics is not None:
            msg.metrics = metrics
        self.episode_pub.publish(msg)

    def _abort(self, goal_handle, result, message):
        self.get_logger().error(f"demonstration aborted: {message}")
        result.success, result.message = False, message
        goal_handle.abort()
        return result


def main(args=None):
    return run_node(TeacherNode, "teacher", args)


if __name__ == "__main__":
    sys.exit(main())
