"""Where the tools' parallel work runs (tric-eval --jobs, tric-study, tric-experiments): a pool of
spawned processes on this machine, or Ray, started here or joined on a cluster at an address.
ROS-free, and light: the tools add and check these options before anything heavy is imported;
Ray is imported only when it is chosen (docs/decisions/executors.md).

Two kinds of work go through an executor:
- episodes: run_episodes(situations, snapshot, jobs, bar, make_evaluator, make_args, agent,
  on_record) -> [EpisodeRecord] in the situations' order, each worker holding one evaluator
  make_evaluator(worker, *make_args()) (worker: its index in [0, jobs) within its pool);
- calls: run_calls(function, calls, jobs, shared) yields (index, result or the Exception it
  raised) as each function(*shared, *calls[index]) ends, at most jobs at once (trainings, the
  candidates of a model's selection); shared: arguments every call takes (a dataset), sent to the
  workers once.
Files a worker reads (model files) go through ship(path) -> what the worker opens with
shipped_files.local_path(); results come back to the caller, who writes them.
"""

import dataclasses
import os

#: The executors a tool may be given (--executor).
EXECUTORS = ("processes", "ray")
#: Each tool's executor when none is named and no Ray address is given
#: (docs/decisions/executors.md): Ray where a run holds many trainings and evaluations, for which
#: it keeps its workers, and for a training's candidates (the trainer node's too); spawned
#: processes for tric-eval's one evaluation, which they start sooner.
DEFAULT_EXECUTORS = {
    "tric-eval": "processes",
    "tric-train": "ray",
    "trainer": "ray",
    "tric-study": "ray",
    "tric-experiments": "ray",
}


def add_executor_arguments(parser, default: str) -> None:
    """--executor (default: default, or ray with an address) and --address on an argparse
    parser."""
    parser.add_argument(
        "--executor",
        choices=EXECUTORS,
        help=f"where parallel work runs: spawned processes here, or Ray tasks and actors (default: "
        f"{default}; ray with an address)",
    )
    parser.set_defaults(default_executor=default)
    parser.add_argument(
        "--address",
        metavar="HOST:PORT",
        help="run on the Ray cluster at this address (default: $RAY_ADDRESS if set, else a local "
        "Ray instance started for the run); results come back to this machine",
    )


@dataclasses.dataclass(frozen=True)
class ExecutorChoice:
    """An executor named by the options: kind "processes" or "ray", and a Ray cluster's address
    (None: a Ray instance of the run's own on this machine)."""

    kind: str
    address: str | None = None

    @property
    def remote(self) -> bool:
        """Whether the workers may be on other machines (no shared disk)."""
        return self.address is not None


def chosen_executor(args) -> ExecutorChoice:
    """The executor of parsed --executor and --address (RAY_ADDRESS standing in for --address, as
    Ray reads it; the tool's default_executor when neither is given); ValueError for --address
    with --executor processes."""
    address = args.address or os.environ.get("RAY_ADDRESS") or None
    kind = args.executor or ("ray" if address else args.default_executor)
    if kind == "processes":
        if args.address:
            raise ValueError("--address runs on a Ray cluster: not with --executor processes")
        address = None
    return ExecutorChoice(kind, address)


def open_executor(choice: ExecutorChoice | None = None, num_cpus: int | None = None):
    """The executor of choice (default: a process pool): ProcessExecutor, or RayExecutor, which
    starts Ray (locally with num_cpus CPUs, None: all) or joins its cluster (the project's code
    sent in its runtime environment) at its first work. Close it after use (it is a context
    manager)."""
    if choice is None or choice.kind == "processes":
        return ProcessExecutor()
    from tric_control.evaluation.ray_executor import RayExecutor

    return RayExecutor(choice.address, num_cpus=num_cpus)


class ProcessExecutor:
    """Episodes in spawned worker processes on this machine (tric_control.evaluation.workers);
    calls in this process."""

    kind = "processes"

    def __enter__(self):
        return self

    def __exit__(self, *_):
        self.close()

    def close(self) -> None:
        pass

    @staticmethod
    def ship(path):
        """Workers share this disk: the path itself."""
        return path

    @staticmethod
    def run_episodes(*args, **kwargs) -> list:
        from tric_control.evaluation.workers import run_in_workers

        return run_in_workers(*args, **kwargs)

    @staticmethod
    def run_calls(function, calls: list, jobs: int, shared: tuple = ()):
        """Yield (index, function(*shared, *calls[index]) or the Exception it raised) as each call
        ends: one after the other in this process when jobs or the calls are 1, else in up to jobs
        spawned worker processes (function: module-level), each given shared once."""
        if jobs <= 1 or len(calls) <= 1:
            for k, call in enumerate(calls):
                try:
                    yield k, function(*shared, *call)
                except Exception as error:
                    yield k, error
            return
        from tric_control.evaluation.workers import calls_in_workers

        yield from calls_in_workers(function, calls, jobs, shared)
