"""tric-record: record teacher demonstrations to MCAP bags, through the real nodes.

    tric-record DATASET|--situations-file FILE [--out DIR] [--overwrite] [--period S] [--duration S]
                [--domain-id N] [--viz [--viz-port P]]

Runs the simulator (lockstep), the teacher and the recorder nodes in one process: for each situation
the teacher demonstrates (action /teacher/demonstrate) and the recorder writes one bag
DIR/<situation>.mcap. DATASET is a built-in data set (sphere_train, cylinder_train, box_train, ...).
DIR must be new or empty unless --overwrite is given (then a bag of the same name is replaced).
Prints a table of the demonstrations' outcomes; exits non-zero if any failed. --viz serves a live
Foxglove view of the run (tric_sim.visualizer_node) on ws://127.0.0.1:P (default 8765).
"""

import argparse
import os
import pathlib
import sys
import threading
import time

import rclpy
from rclpy.action import ActionClient
from rclpy.context import Context
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter
from tqdm import tqdm

from tric_learning.recorder_node import RecorderNode
from tric_msgs.action import Demonstrate
from tric_sim import messages
from tric_sim.output_files import check_output_folder
from tric_sim.simulator_node import IN_PROCESS_LOCKSTEP_TIMEOUT_S, SimulatorNode
from tric_sim.situations import DATASETS, dataset, load_situations
from tric_sim.teacher_node import TeacherNode
from tric_sim.visualizer_node import VisualizerNode, add_view_arguments, open_view


def private_domain_id() -> int:
    """A DDS domain for an in-process graph that no other graph should share: the simulator's
    topics (/joint_states, /situation, ...) must not mix with those of another simulator or robot
    on the same network. Chosen from the process id in 1..100 (0 is left to the user's own
    graph)."""
    return 1 + os.getpid() % 100


class InProcessGraph:
    """Nodes spun by one SingleThreadedExecutor in a background thread, on a context of their own.

    domain_id: the DDS domain of the context (None: the environment's ROS_DOMAIN_ID). Discovery is
    limited to this machine unless ROS_AUTOMATIC_DISCOVERY_RANGE says otherwise."""

    def __init__(self, domain_id: int = None):
        os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
        self.context = Context()
        rclpy.init(context=self.context, domain_id=domain_id)
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
    deadline = time.monotonic() + timeout
    while not future.done():
        if time.monotonic() > deadline:
            raise TimeoutError(f"timed out after {timeout:g} s waiting for {what}")
        time.sleep(0.005)
    return future.result()


def demonstrate_all(
    situations,
    out: pathlib.Path,
    period: float,
    duration: float,
    progress=True,
    domain_id: int = None,
    view=None,
    overwrite: bool = False,
):
    """Demonstrate and record every situation; returns [(situation, result, bag path or None)]
    (None with result.message saying why, when the recorder could not write the bag).
    domain_id: the graph's DDS domain (None: the environment's); view: a FoxgloveView to show the
    run in (None: no visualizer); overwrite: the recorder's parameter."""
    graph = InProcessGraph(domain_id)
    try:
        graph.add(
            SimulatorNode(
                context=graph.context,
                parameter_overrides=[
                    Parameter("mode", value="lockstep"),
                    Parameter("lockstep_timeout_s", value=IN_PROCESS_LOCKSTEP_TIMEOUT_S),
                ],
            )
        )
        if view is not None:
            graph.add(VisualizerNode(view=view, context=graph.context))
        graph.add(TeacherNode(context=graph.context))
        recorder = graph.add(
            RecorderNode(
                context=graph.context,
                parameter_overrides=[
                    Parameter("output_dir", value=str(out)),
                    Parameter("sample_period_s", value=period),
                    Parameter("overwrite", value=overwrite),
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
            deadline = time.monotonic() + 30.0
            while (
                len(recorder.finished) == done_before
                and len(recorder.failed) == failed_before
                and result.success
                and time.monotonic() < deadline
            ):
                time.sleep(0.01)
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


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="tric-record", description=__doc__.splitlines()[0])
    parser.add_argument("dataset", nargs="?", choices=sorted(DATASETS), help="a built-in data set")
    parser.add_argument("--situations-file", help="a YAML/JSON situations file instead of DATASET")
    parser.add_argument(
        "--out",
        default="recordings",
        help="folder for the bags, empty or new unless --overwrite (default: recordings)",
    )
    parser.add_argument(
        "--overwrite",
        action="store_true",
        help="record into a folder that holds files already: a bag of the same name is "
        "replaced, other files are kept",
    )
    parser.add_argument("--period", type=float, default=0.125, help="sampling period, simulated s")
    parser.add_argument(
        "--duration",
        type=float,
        default=0.0,
        help="demonstration length, simulated s (default: 5 s grasps, 8 s boxes)",
    )
    parser.add_argument(
        "--domain-id",
        type=int,
        default=None,
        help="DDS domain of the in-process nodes (default: a private one, 1 + pid %% 100, "
        "so that they never mix with another simulator's topics)",
    )
    add_view_arguments(parser)
    args = parser.parse_args(argv)
    if bool(args.dataset) == bool(args.situations_file):
        parser.error("give either DATASET or --situations-file")
    if not args.period > 0 or args.duration < 0:
        parser.error("--period must be positive and --duration not negative")
    try:
        situations = (
            load_situations(args.situations_file) if args.situations_file else dataset(args.dataset)
        )
        out = check_output_folder(args.out, "--out", must_be_empty=not args.overwrite)
    except ValueError as error:
        hint = "; give --overwrite to record into it anyway" if "is not empty" in str(error) else ""
        print(f"tric-record: {error}{hint}", file=sys.stderr)
        return 2
    domain_id = private_domain_id() if args.domain_id is None else args.domain_id
    if not 0 <= domain_id <= 232:
        parser.error("--domain-id must be in [0, 232]")
    print(f"tric-record: nodes in DDS domain {domain_id}", file=sys.stderr)
    try:
        view = open_view(args, "tric-record")
    except ValueError as error:
        print(f"tric-record: {error}", file=sys.stderr)
        return 2
    start = time.monotonic()
    try:
        rows = demonstrate_all(
            situations,
            out,
            args.period,
            args.duration,
            domain_id=domain_id,
            view=view,
            overwrite=args.overwrite,
        )
    finally:
        if view is not None:
            view.close()
    print(
        f"\n{'situation':24s} {'success':>7s} {'grasp cost':>10s} {'lift':>5s} {'lid (rad)':>9s}  "
        "bag"
    )
    for situation, result, path in rows:
        m = result.metrics
        print(
            f"{situation.name:24s} {str(result.success and m.success):>7s} {m.grasp_cost:10.3f} "
            f"{'yes' if m.lift_passed else '-':>5s} {m.lid_angle:9.2f}  {path or result.message}"
        )
    failed = [s.name for s, r, p in rows if not (r.success and r.metrics.success and p)]
    print(
        f"\n{len(rows) - len(failed)} of {len(rows)} demonstrations succeeded and were recorded "
        f"in {time.monotonic() - start:.1f} s"
    )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
