"""The simulator node: PyBullet physics behind standard ROS topics.

Publishes every control period /joint_states (sensor_msgs/JointState), /object_poses
(tric_msgs/ObjectPoses) and, while someone subscribes (a node with use_sim_time does), /clock
(rosgraph_msgs/Clock, the simulated time); publishes the current
situation on /situation (latched) after every reset; takes position targets on /joint_command
(sensor_msgs/JointState: names with positions in rad, any subset of the joints; the others hold).

Modes (parameter `mode`):
- "realtime": one control period per wall-clock period.
- "lockstep": the period after the state stamped t is simulated as soon as a command stamped t (or
  with a zero stamp) arrives, or after `lockstep_timeout_s` of wall time without one. Commanders
  copy the stamp of the /joint_states message they answer into their command's header.

Services: ~/reset_scene (tric_msgs/ResetScene), ~/perturb (tric_msgs/Perturb: pushes and target
moves scheduled within the current episode, besides the situation's own), ~/evaluate_task
(tric_msgs/EvaluateTask, the hidden metrics), ~/render_scene (tric_msgs/RenderScene, an RGB
snapshot).
A command with unknown joints, mismatched sizes, NaN/inf or targets outside the joint limits is
refused with a logged reason; the joints then hold their previous targets.
"""

import sys
import threading
import time

import numpy as np
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.event_handler import PublisherEventCallbacks
from rclpy.node import Node
from rclpy.parameter import Parameter
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import Image, JointState

from tric_msgs.msg import ObjectPoses
from tric_msgs.msg import Situation as SituationMsg
from tric_msgs.srv import EvaluateTask, Perturb, RenderScene, ResetScene
from tric_sim.physics import metrics
from tric_sim.physics.simulation import PhysicsWorld
from tric_sim.ros import messages
from tric_sim.ros.graph import LATCHED_QOS, STATE_QOS, run_node
from tric_sim.ros.parameters import POSITIVE, Range, declare, declare_robot
from tric_sim.ros.topic_poller import TopicPoller
from tric_sim.world.robot_profile import DEFAULT_ROBOT
from tric_sim.world.situations import find_situation

#: lockstep_timeout_s for a simulator whose commanders run in the same process (the in-process
#: tools): they answer every state, so a late answer means a busy machine, not a missing commander,
#: and stepping without it would make the episode depend on the machine's load.
IN_PROCESS_LOCKSTEP_TIMEOUT_S = 60.0


class SimulatorNode(Node):
    """PyBullet simulator of the arm + hand and a situation's scene (see the module docstring)."""

    def __init__(self, **kwargs):
        super().__init__("simulator", **kwargs)
        self.mode = declare(
            self, "mode", "realtime", "how the simulation advances", ("realtime", "lockstep")
        )
        control_rate = declare(
            self, "control_rate_hz", 100.0, "control periods per second", Range(1.0, 1000.0)
        )
        physics_rate = declare(
            self,
            "physics_rate_hz",
            300.0,
            "physics steps per second (a multiple of the control rate)",
            Range(240.0, 100000.0),
        )
        iterations = declare(
            self, "solver_iterations", 10, "constraint-solver iterations per step", Range(1, 1000)
        )
        gui = declare(self, "gui", False, "open the PyBullet GUI (needs a display)")
        self.lockstep_timeout = declare(
            self,
            "lockstep_timeout_s",
            1.0,
            "lockstep: wall seconds to wait for a command before stepping anyway",
            POSITIVE,
        )
        situation_name = declare(self, "situation", "sphere_test_00", "initial situation's name")
        situations_file = declare(
            self,
            "situations_file",
            "",
            "YAML/JSON situations file to find `situation` in; empty: built-in sets",
        )

        self.robot = declare_robot(self)
        self.world = PhysicsWorld(self.robot, physics_rate, control_rate, iterations, gui)
        self.joint_index = {name: i for i, name in enumerate(self.robot.joint_names)}
        group = MutuallyExclusiveCallbackGroup()
        # The per-period topics skip rclpy's default QoS-event handlers: each is one more entity the
        # executor polls every period, which costs lockstep speed.
        lean = {"event_callbacks": PublisherEventCallbacks(use_default_callbacks=False)}
        self.state_pub = self.create_publisher(JointState, "/joint_states", STATE_QOS, **lean)
        self.poses_pub = self.create_publisher(ObjectPoses, "/object_poses", STATE_QOS, **lean)
        self.clock_pub = self.create_publisher(Clock, "/clock", STATE_QOS, **lean)
        self.situation_pub = self.create_publisher(SituationMsg, "/situation", LATCHED_QOS)
        self._lock = threading.Lock()  # the world is used by the executor's and the lockstep thread
        self._stop = threading.Event()
        if self.mode == "lockstep":
            # Lockstep's hot path (command in, step, state out) runs in a thread of its own that
            # waits on /joint_command directly (see tric_sim.ros.topic_poller).
            self._commands = TopicPoller(
                self.context,
                "simulator_lockstep",
                {"command": (JointState, "/joint_command", STATE_QOS)},
            )
        else:
            self.create_subscription(
                JointState, "/joint_command", self._on_command, STATE_QOS, callback_group=group
            )
        self.create_service(ResetScene, "~/reset_scene", self._on_reset, callback_group=group)
        self.create_service(Perturb, "~/perturb", self._on_perturb, callback_group=group)
        self.create_service(
            EvaluateTask, "~/evaluate_task", self._on_evaluate, callback_group=group
        )
        self.create_service(RenderScene, "~/render_scene", self._on_render, callback_group=group)

        self.world.reset(
            find_situation(situation_name, situations_file or None, self.robot.profile.workspace)
        )
        self._state_msg = JointState(name=list(self.robot.joint_names))
        self._clock_msg = Clock()
        self._last_publish = time.monotonic()
        self._publish_situation()
        self._publish_state()
        if self.mode == "realtime":
            self.create_timer(self.world.control_period, self._on_timer, callback_group=group)
        else:
            self._lockstep_thread = threading.Thread(
                target=self._lockstep_loop, daemon=True, name="simulator_lockstep"
            )
            self._lockstep_thread.start()
        self.get_logger().info(
            f"simulating '{self.world.situation.name}' in {self.mode} mode: control "
            f"{control_rate:g} Hz, physics {physics_rate:g} Hz ({self.world.substeps} substeps)"
        )

    def destroy_node(self):
        self._stop.set()
        if self.mode == "lockstep":
            self._lockstep_thread.join()
            self._commands.destroy()
        with self._lock:
            self.world.close()
        return super().destroy_node()

    # --- stepping ------------------------------------------------------------------------------

    def _advance(self):
        self.world.step()
        self._publish_state()

    def _publish_state(self):
        """Publish /clock, /object_poses and, last, /joint_states: commanders answer /joint_states,
        so the other two are out by then."""
        stamp_ns = self.world.time_ns
        stamp = messages.time_msg(stamp_ns)
        if self.clock_pub.get_subscription_count():  # lockstep graphs run without use_sim_time
            self._clock_msg.clock = stamp
            self.clock_pub.publish(self._clock_msg)
        self.poses_pub.publish(messages.object_poses_msg(self.world.object_poses(), stamp_ns))
        positions, velocities = self.world.joint_state()
        msg = self._state_msg
        msg.header.stamp = stamp
        msg.position = positions.tolist()
        msg.velocity = velocities.tolist()
        self.state_pub.publish(msg)
        self._last_publish = time.monotonic()

    def _publish_situation(self):
        self.situation_pub.publish(messages.situation_to_msg(self.world.situation))

    def _on_timer(self):
        """Realtime mode: one period per wall-clock control period."""
        with self._lock:
            self._advance()

    def _on_command(self, msg: JointState):
        """Realtime mode: the latest valid command sets the targets."""
        with self._lock:
            self._refuse_or_apply(msg)

    def _lockstep_loop(self):
        """Lockstep mode: step when the command for the current state arrives, or on timeout."""
        while not self._stop.is_set() and self.context.ok():
            commands = self._commands.poll(0.05)["command"]
            with self._lock:
                current = self.world.time_ns
                answered = False
                for msg in commands:
                    if messages.time_ns(msg.header.stamp) in (0, current):
                        self._refuse_or_apply(msg)
                        answered = True
                if answered or time.monotonic() - self._last_publish >= self.lockstep_timeout:
                    self._advance()

    def _refuse_or_apply(self, msg: JointState):
        error = self._apply_command(msg)
        if error:
            self.get_logger().warning(
                f"refused /joint_command ({error}); joints hold", throttle_duration_sec=1.0
            )

    def _apply_command(self, msg: JointState):
        """Set the targets named in msg; returns why the command was refused, or None."""
        if len(msg.name) != len(msg.position):
            return f"{len(msg.name)} names but {len(msg.position)} positions"
        targets = self.world.targets.copy()
        if list(msg.name) == self._state_msg.name:  # all joints, in the published order
            targets[:] = msg.position
        else:
            if len(set(msg.name)) != len(msg.name):
                return "a joint is named twice"
            unknown = [name for name in msg.name if name not in self.joint_index]
            if unknown:
                return f"unknown joint(s) {', '.join(unknown)}"
            targets[[self.joint_index[name] for name in msg.name]] = msg.position
        try:
            self.robot.check_configuration(targets, "target")
        except ValueError as error:
            return str(error)
        self.world.command(targets)
        return None

    # --- services ------------------------------------------------------------------------------

    def _on_reset(self, request, response):
        with self._lock:
            return self._reset(request, response)

    def _reset(self, request, response):
        try:
            situation = messages.situation_from_msg(request.situation, self.robot.n_joints)
            self.world.reset(situation)
        except ValueError as error:
            response.success, response.message = False, f"reset refused: {error}"
            self.get_logger().warning(response.message)
            return response
        self._publish_situation()
        self._publish_state()
        response.success, response.message = True, f"scene reset to '{situation.name}'"
        response.objects = messages.object_poses_msg(self.world.object_poses(), self.world.time_ns)
        positions, velocities = self.world.joint_state()
        response.joint_state = messages.joint_state_msg(
            self.robot.joint_names, positions, velocities, self.world.time_ns
        )
        return response

    def _on_perturb(self, request, response):
        with self._lock:
            try:
                self.world.schedule(map(messages.perturbation_from_msg, request.perturbations))
            except ValueError as error:
                response.success, response.message = False, f"perturbation refused: {error}"
                self.get_logger().warning(response.message)
                return response
            self._publish_situation()
        response.success = True
        response.message = f"{len(request.perturbations)} perturbation(s) scheduled"
        return response

    def _on_evaluate(self, request, response):
        with self._lock:
            return self._evaluate(request, response)

    def _evaluate(self, request, response):
        try:
            result = metrics.evaluate(self.world, self.robot, request.run_lift_test)
        except ValueError as error:
            response.success, response.message = False, str(error)
            return response
        if request.run_lift_test:
            self._publish_state()
        response.success, response.message = True, "evaluated"
        response.metrics = messages.metrics_msg(result)
        return response

    def _on_render(self, request, response):
        if not (16 <= request.width <= 4096 and 16 <= request.height <= 4096):
            response.success, response.message = (
                False,
                "width and height must be in [16, 4096] pixels",
            )
            return response
        if not 1.0 <= request.fov_deg <= 170.0:
            response.success, response.message = False, "fov_deg must be in [1, 170]"
            return response
        eye = [request.eye.x, request.eye.y, request.eye.z]
        target = [request.target.x, request.target.y, request.target.z]
        if not np.all(np.isfinite(eye + target)):
            response.success, response.message = False, "eye and target must be finite"
            return response
        with self._lock:
            rgb = self.world.render(request.width, request.height, eye, target, request.fov_deg)
        response.image = Image(
            height=rgb.shape[0],
            width=rgb.shape[1],
            encoding="rgb8",
            is_bigendian=0,
            step=3 * rgb.shape[1],
            data=rgb.tobytes(),
        )
        response.image.header.stamp = messages.time_msg(self.world.time_ns)
        response.image.header.frame_id = "world"
        response.success, response.message = True, "rendered"
        return response


def lockstep_simulator(context, robot: str = DEFAULT_ROBOT) -> SimulatorNode:
    """A simulator node of robot (a profile's name or file) in lockstep mode for an in-process
    graph on context (its commanders answer every state: lockstep_timeout_s
    IN_PROCESS_LOCKSTEP_TIMEOUT_S)."""
    return SimulatorNode(
        context=context,
        parameter_overrides=[
            Parameter("mode", value="lockstep"),
            Parameter("lockstep_timeout_s", value=IN_PROCESS_LOCKSTEP_TIMEOUT_S),
            Parameter("robot", value=robot),
        ],
    )


def main(args=None):
    return run_node(SimulatorNode, "simulator", args)


if __name__ == "__main__":
    sys.exit(main())
