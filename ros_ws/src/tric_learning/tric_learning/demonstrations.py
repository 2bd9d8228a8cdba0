"""Teacher demonstrations recorded through the real nodes: the simulator (lockstep), the teacher
and the recorder in one in-process graph, one MCAP bag per situation (tric-record, tric-demo and
tric-experiments record with it)."""

import pathlib

from rclpy.action import ActionClient
from rclpy.node import Node
from rclpy.parameter import Parameter
from tqdm import tqdm

from tric_learning.recorder_node import RecorderNode
from tric_msgs.action import Demonstrate
from tric_sim.ros import messages
from tric_sim.ros.graph import InProcessGraph, wait
from tric_sim.simulator_node import lockstep_simulator
from tric_sim.teacher_node import TeacherNode
from tric_sim.visualizer_node import VisualizerNode
from tric_sim.world.robot_profile import DEFAULT_ROBOT


def demonstrate_all(
    situations,
    out: pathlib.Path,
    period: float,
    duration: float,
    progress=True,
    domain_id: int = None,
    view=None,
    overwrite: bool = False,
    robot: str = DEFAULT_ROBOT,
):
    """Demonstrate and record every situation; returns [(situation, result, bag path or None)]
    (None with result.message saying why, when the recorder could not write the bag).
    domain_id: the graph's DDS domain (None: the environment's); view: a FoxgloveView to show the
    run in (None: no visualizer); overwrite: the recorder's parameter; robot: the robot, a profile's
    name or file (docs/robots.md), a parameter of every node."""
    graph = InProcessGraph(domain_id)
    try:
        robot_parameter = Parameter("robot", value=robot)
        graph.add(lockstep_simulator(graph.context, robot))
        if view is not None:
            graph.add(
                VisualizerNode(
                    view=view, context=graph.context, parameter_overrides=[robot_parameter]
                )
            )
        graph.add(TeacherNode(context=graph.context, parameter_overrides=[robot_parameter]))
        recorder = graph.add(
            RecorderNode(
                context=graph.context,
                parameter_overrides=[
                    Parameter("output_dir", value=str(out)),
                    Parameter("sample_period_s", value=period),
                    Parameter("overwrite", value=overwrite),
                    robot_parameter,
                ],
            )
        )
        client_node = graph.add(Node("tric_record", context=graph.context))
        client = ActionClient(client_node, Demonstrate, "/teacher/demonstrate")
        graph.start()
        if not client.wait_for_server(timeout_sec=30.0):
            raise RuntimeError("the teacher's demonstrate action did not come up")
        rows = []
        bar = tqdm(situations, desc="demonstrating", unit="demo", disable=not progress)
        for situation in bar:
            bar.set_postfix_str(situation.name)
            done_before, failed_before = len(recorder.finished), len(recorder.failed)
            goal = Demonstrate.Goal(
                situation=messages.situation_to_msg(situation),
                episode_id=situation.name,
                duration=duration,
            )
            handle = wait(client.send_goal_async(goal), 30.0, "the teacher to accept the goal")
            if not handle.accepted:
                raise RuntimeError(f"the teacher refused '{situation.name}'")
            result = wait(
                handle.get_result_async(), 600.0, f"the demonstration of '{situation.name}'"
            ).result
            if result.success:  # the recorder closes the episode's bag, or names why not
                with recorder.changed:
                    recorder.changed.wait_for(
                        lambda before=(done_before, failed_before): (
                            len(recorder.finished) > before[0] or len(recorder.failed) > before[1]
                        ),
                        timeout=30.0,
                    )
            path = recorder.finished[-1] if len(recorder.finished) > done_before else None
            if path is None and result.success:
                result.success = False
                result.message = (
                    f"not recorded: {recorder.failed[-1][1]}"
                    if len(recorder.failed) > failed_before
                    else "the recorder wrote no bag within 30 s"
                )
            rows.append((situation, result, path))
        return rows
    finally:
        graph.close()
