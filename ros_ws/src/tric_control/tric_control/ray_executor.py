"""Ray as the executor (tric_control.executors): episodes run on Ray actors, each holding one
evaluator as a spawned worker process does, and calls (trainings) are Ray tasks. Started locally
with no set-up, or joined on a cluster at an address; either way the project's code (its three
Python packages) and the bag folders the run needs reach the workers through Ray's runtime
environment (py_modules and working_dir), not a shared disk, and results come back to the caller.
The workers' machines need the project's environment (make setup: the libraries and the built
messages). ROS-free."""

import collections
import pathlib
import shutil
import tempfile

import ray

import tric_control
import tric_learning
import tric_sim
from tric_control.evaluation import EpisodeRecord, unjudged_fields
from tric_control.executors import ShippedFile

#: Ray's object store on a local start, bytes: the work passes situations, model files and records
#: (kilobytes to megabytes), never datasets.
LOCAL_OBJECT_STORE_BYTES = 100 * 2**20
#: Seconds an actor is given to close its evaluator (its graph) before it is killed.
CLOSE_TIMEOUT_S = 30.0
#: The bag folders' parent, relative to the caller's working directory and to the workers'.
BAGS = pathlib.Path("bags")


class RayExecutor:
    """Ray started here (address None, with num_cpus CPUs, None: all) or joined at address; bags:
    the names of the folders under bags/ that the workers read. node_work counts the episodes and
    calls each node (by Ray node id) ran."""

    kind = "ray"

    def __init__(self, address: str = None, num_cpus: int = None, bags=()):
        if ray.is_initialized():
            raise RuntimeError("Ray is already initialized in this process")
        self._staging = pathlib.Path(tempfile.mkdtemp(prefix="tric-ray-"))
        runtime_env = {
            "py_modules": [
                str(pathlib.Path(package.__file__).resolve().parent)
                for package in (tric_sim, tric_learning, tric_control)
            ],
            "env_vars": {"RAY_USAGE_STATS_ENABLED": "0"},
        }
        if bags:
            for name in sorted(set(bags)):
                shutil.copytree(BAGS / name, self._staging / BAGS / name)
            runtime_env["working_dir"] = str(self._staging)
        local = {} if address else {"num_cpus": num_cpus, "include_dashboard": False}
        if not address:
            local["object_store_memory"] = LOCAL_OBJECT_STORE_BYTES
        try:
            ray.init(
                address=address or "local",
                runtime_env=runtime_env,
                log_to_driver=False,
                configure_logging=False,
                **local,
            )
        except BaseException:
            shutil.rmtree(self._staging, ignore_errors=True)
            raise
        self.node_work = collections.Counter()

    def __enter__(self):
        return self

    def __exit__(self, *_):
        self.close()

    def close(self) -> None:
        """Shut Ray down (a local instance ends; a cluster keeps running)."""
        ray.shutdown()
        shutil.rmtree(self._staging, ignore_errors=True)

    @staticmethod
    def ship(path):
        """A model file's bytes for the workers (None stays None)."""
        if path is None:
            return None
        path = pathlib.Path(path)
        if not path.is_file():  # the workers' evaluators refuse it, with the caller's path
            return str(path)
        return ShippedFile(path.name, path.read_bytes())

    def run_episodes(
        self, situations, snapshot, jobs, bar, make_evaluator, make_args, agent, on_record=None
    ) -> list:
        """As evaluation_workers.run_in_workers, on jobs Ray actors: [EpisodeRecord] in the
        situations' order, bar advanced and on_record(record) called as each ends. An actor that
        dies loses its episode to a rerun alone on a fresh actor (the others go on); one whose actor
        dies again is a failed record that says so. Any other error ends the run and is raised."""
        snapshot = None if snapshot is None else pathlib.Path(snapshot).resolve()
        records = [None] * len(situations)

        def ended(k):
            bar.set_postfix_str(situations[k].name)
            bar.update()
            if on_record is not None:
                on_record(records[k])

        lost = self._run_actors(
            situations, range(len(situations)), records, jobs, snapshot, ended, make_evaluator,
            make_args(),
        )  # fmt: skip
        lost_twice = []
        for k in lost:
            lost_twice += self._run_actors(
                situations, [k], records, 1, snapshot, ended, make_evaluator, make_args()
            )
        agent = next((record.agent for record in records if record is not None), agent)
        for k in lost_twice:
            records[k] = EpisodeRecord(
                **unjudged_fields(situations[k], agent),
                wall_time_s=0.0,
                outcome="failed",
                message="its evaluation worker process died, twice",
            )
            ended(k)
        return records

    def _run_actors(
        self, situations, pending, records, jobs, snapshot, ended, make_evaluator, args
    ) -> list:
        """Run the pending episodes (indices) on up to jobs actors, one at a time each, filling
        records; the indices whose actor died. A dead actor is replaced by a fresh one of its
        worker index while episodes remain."""
        todo = collections.deque(pending)
        actors = {}
        running = {}  # an episode's result ref -> (episode index, worker index)
        lost = []

        def start(worker):
            if worker not in actors:
                actors[worker] = _EpisodeWorker.options(
                    num_cpus=1, max_restarts=0, max_task_retries=0, scheduling_strategy="SPREAD"
                ).remote(make_evaluator, worker, args)
            k = todo.popleft()
            running[actors[worker].run.remote(situations[k], snapshot)] = (k, worker)

        try:
            for worker in range(min(jobs, len(todo))):
                start(worker)
            while running:
                [done], _ = ray.wait(list(running), num_returns=1)
                k, worker = running.pop(done)
                try:
                    records[k], node = ray.get(done)
                except ray.exceptions.RayActorError:
                    lost.append(k)
                    actors.pop(worker)
                except ray.exceptions.RayTaskError as error:
                    raise error.cause from None
                else:
                    self.node_work[node] += 1
                    ended(k)
                if todo:
                    start(worker)
        finally:
            _close(list(actors.values()))
        return lost

    def run_calls(self, function, calls: list, jobs: int):
        """Yield (index, function(*calls[index]) or the Exception it raised) as each call ends, the
        calls run as Ray tasks (one CPU each, at most jobs at once; function: module-level)."""
        remote = _call_on_node.options(num_cpus=1, max_retries=0, scheduling_strategy="SPREAD")
        todo = collections.deque(enumerate(calls))
        running = {}
        try:
            while todo or running:
                while todo and len(running) < max(jobs, 1):
                    k, call = todo.popleft()
                    running[remote.remote(function, call)] = k
                [done], _ = ray.wait(list(running), num_returns=1)
                k = running.pop(done)
                try:
                    result, node = ray.get(done)
                except ray.exceptions.RayTaskError as error:
                    yield k, error.cause if isinstance(error.cause, Exception) else error
                except ray.exceptions.RayError as error:  # its worker died
                    yield k, error
                else:
                    self.node_work[node] += 1
                    yield k, result
        finally:
            for ref in running:
                ray.cancel(ref, force=True)


@ray.remote
def _call_on_node(function, call):
    """(function(*call), the id of the node it ran on)."""
    return function(*call), ray.get_runtime_context().get_node_id()


@ray.remote
class _EpisodeWorker:
    """One evaluator (make_evaluator(worker, *args)) held by a Ray actor; its construction's error,
    if it failed, raised by each run (as evaluation_workers' workers do)."""

    def __init__(self, make_evaluator, worker, args):
        self.evaluator, self.error = None, None
        try:
            self.evaluator = make_evaluator(worker, *args)
        except Exception as error:
            self.error = error

    def run(self, situation, snapshot):
        """(the episode's EpisodeRecord, the id of the node it ran on)."""
        if self.error is not None:
            raise self.error
        return self.evaluator.run(situation, snapshot), ray.get_runtime_context().get_node_id()

    def close(self):
        if self.evaluator is not None:
            self.evaluator.close()


def _close(actors) -> None:
    """Close the actors' evaluators (a graph leaves its DDS domain), then end the actors."""
    closing = [actor.close.remote() for actor in actors]
    try:
        ray.wait(closing, num_returns=len(closing), timeout=CLOSE_TIMEOUT_S)
    finally:
        for actor in actors:
            ray.kill(actor)
