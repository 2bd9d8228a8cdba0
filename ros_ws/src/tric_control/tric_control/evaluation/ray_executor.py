"""Ray as the executor (tric_control.evaluation.executors): episodes run on Ray actors, each holding
one evaluator as a spawned worker process does, and calls (trainings) are Ray tasks. Ray starts
locally with no set-up (its workers share this machine's packages and files), or joins a cluster
at an address: there the project's code (its three Python packages) reaches the workers through
Ray's runtime environment (py_modules), not a shared disk; model files go as bytes, the datasets
of trainings through Ray's object store, and results come back to the caller, who writes them. The
cluster's machines need the project's environment (make setup: the libraries and the built
messages). ROS-free."""

import collections
import logging
import pathlib
import signal
import threading
from typing import Any

import ray

import tric_control
import tric_learning
import tric_sim
from tric_control.evaluation.records import EpisodeRecord, unjudged_fields
from tric_control.evaluation.shipped_files import ShippedFile

#: Ray's object store on a local start, bytes: the work passes situations, model files, records
#: and tric-experiments' training datasets (up to about 30 MB).
LOCAL_OBJECT_STORE_BYTES = 100 * 2**20
#: Seconds an actor is given to close its evaluator (its graph) before it is killed.
CLOSE_TIMEOUT_S = 30.0
#: The signals that end a tool (tric_sim.tools.interrupts).
ENDING_SIGNALS = (signal.SIGINT, signal.SIGTERM)
#: The logger of Ray's line about token authentication at every local start.
AUTHENTICATION_LOGGER = "ray._private.authentication.authentication_token_setup"


class RayExecutor:
    """Ray started here (address None, with num_cpus CPUs, None: all; its workers share this
    machine's packages and working directory) or joined at address (the project's packages sent
    in the runtime environment). node_work counts the episodes and calls each node (by Ray node id)
    ran."""

    kind = "ray"

    def __init__(self, address: str | None = None, num_cpus: int | None = None):
        if ray.is_initialized():
            raise RuntimeError("Ray is already initialized in this process")
        self.address, self.num_cpus = address, num_cpus
        self.node_work: collections.Counter[str] = collections.Counter()
        self._actors: dict[int, Any] = {}
        self._calls = 0
        self._started = False
        self._handlers: dict[int, Any] = {}

    def _start(self) -> None:
        """Start or join Ray, once (at the first work: a run with nothing to do starts nothing)."""
        if self._started:
            return
        self._started = True
        settings: dict[str, Any]
        if self.address:
            settings = {"runtime_env": self._runtime_env()}
        else:
            settings = {
                "num_cpus": self.num_cpus,
                "object_store_memory": LOCAL_OBJECT_STORE_BYTES,
                "include_dashboard": False,
            }
        self._handlers = {signum: signal.getsignal(signum) for signum in ENDING_SIGNALS}
        # a local start keeps Ray's default, token authentication, without its line about it
        logging.getLogger(AUTHENTICATION_LOGGER).setLevel(logging.ERROR)
        ray.init(
            address=self.address or "local",
            log_to_driver=False,
            configure_logging=False,
            **settings,
        )
        if threading.current_thread() is threading.main_thread():
            for signum in ENDING_SIGNALS:
                signal.signal(signum, self._shut_down_then_end)

    def _shut_down_then_end(self, signum, frame):
        """SIGINT or SIGTERM: shut Ray down (a local instance's processes would outlive a tool
        that exits at once), then end as the tool's own handler does (tric_sim.tools.interrupts)."""
        ray.shutdown()
        handler = self._handlers[signum]
        signal.signal(signum, handler)
        if callable(handler):
            handler(signum, frame)
        else:
            signal.raise_signal(signum)

    @staticmethod
    def _runtime_env() -> dict:
        """The runtime environment of a cluster's workers: the project's Python packages."""
        return {
            "py_modules": [
                str(pathlib.Path(str(package.__file__)).resolve().parent)
                for package in (tric_sim, tric_learning, tric_control)
            ]
        }

    def __enter__(self):
        return self

    def __exit__(self, *_):
        self.close()

    def close(self) -> None:
        """End the actors and shut Ray down (a local instance ends; a cluster keeps running)."""
        if not self._started:
            return
        try:
            if ray.is_initialized():
                self._end_actors()
        finally:
            ray.shutdown()
            if threading.current_thread() is threading.main_thread():
                for signum, handler in self._handlers.items():
                    signal.signal(signum, handler)
            self._started = False

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
        situations' order, bar advanced and on_record(record) called as each ends. The actors
        outlive the call: each keeps its process and builds its evaluator anew for each call,
        closing it when the call ends (a graph left open would stay on its DDS domain, where the
        caller may run a graph of its own next: docs/decisions/executors.md); they hold no CPU of
        Ray's between calls (num_cpus 0: jobs bounds them, and a training task between two
        evaluations finds its CPU), spread over the nodes. An
        actor that dies loses its episode to a second try on a fresh actor (the others go on); one
        whose actor dies again is a failed record that says so. Any other error ends the run and
        is raised."""
        self._start()
        snapshot = None if snapshot is None else pathlib.Path(snapshot).resolve()
        self._calls += 1
        setup = ray.put((self._calls, make_evaluator, make_args()))
        records: list[Any] = [None] * len(situations)
        todo = collections.deque(range(len(situations)))
        deaths: collections.Counter[int] = collections.Counter()
        running: dict[Any, tuple[int, int]] = {}  # a result's ref -> (episode, worker index)

        def start(worker):
            if worker not in self._actors:
                self._actors[worker] = _EpisodeWorker.options(
                    num_cpus=0, max_restarts=0, max_task_retries=0, scheduling_strategy="SPREAD"
                ).remote(worker)
            k = todo.popleft()
            running[self._actors[worker].run.remote(setup, situations[k], snapshot)] = (k, worker)

        def ended(k):
            bar.set_postfix_str(situations[k].name)
            bar.update()
            if on_record is not None:
                on_record(records[k])

        try:
            for worker in range(min(jobs, len(todo))):
                start(worker)
            while running:
                [done], _ = ray.wait(list(running), num_returns=1)
                k, worker = running.pop(done)
                try:
                    records[k], node = ray.get(done)
                except ray.exceptions.RayActorError:
                    del self._actors[worker]
                    deaths[k] += 1
                    if deaths[k] == 1:
                        todo.append(k)
                except ray.exceptions.RayTaskError as error:
                    raise error.cause from None
                else:
                    self.node_work[node] += 1
                    ended(k)
                if todo:
                    start(worker)
        except BaseException:
            self._end_actors()
            raise
        self._close_evaluators(list(self._actors.values()))
        agent = next((record.agent for record in records if record is not None), agent)
        for k in [k for k, count in deaths.items() if count > 1]:
            records[k] = EpisodeRecord(
                **unjudged_fields(situations[k], agent),
                wall_time_s=0.0,
                outcome="failed",
                message="its evaluation worker process died, twice",
            )
            ended(k)
        return records

    def _end_actors(self) -> None:
        """Close the actors' evaluators, then end the actors."""
        actors = list(self._actors.values())
        self._actors.clear()
        try:
            self._close_evaluators(actors)
        finally:
            for actor in actors:
                ray.kill(actor)

    @staticmethod
    def _close_evaluators(actors) -> None:
        """Close the evaluators of actors (each graph leaves its DDS domain), waiting
        CLOSE_TIMEOUT_S at most."""
        closing = [actor.close.remote() for actor in actors]
        ray.wait(closing, num_returns=len(closing), timeout=CLOSE_TIMEOUT_S)

    def run_calls(self, function, calls: list, jobs: int, shared: tuple = ()):
        """Yield (index, function(*shared, *calls[index]) or the Exception it raised) as each call
        ends, the calls run as Ray tasks (one CPU each, at most jobs at once; function:
        module-level); shared goes to the object store once."""
        self._start()
        remote = _call_on_node.options(num_cpus=1, max_retries=0, scheduling_strategy="SPREAD")
        references = [ray.put(value) for value in shared]
        todo = collections.deque(enumerate(calls))
        running: dict[Any, int] = {}
        try:
            while todo or running:
                while todo and len(running) < max(jobs, 1):
                    k, call = todo.popleft()
                    running[remote.remote(function, call, *references)] = k
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
def _call_on_node(function, call, *shared):
    """(function(*shared, *call), the id of the node it ran on); Ray hands shared (object
    references) over as their values."""
    return function(*shared, *call), ray.get_runtime_context().get_node_id()


@ray.remote
class _EpisodeWorker:
    """A Ray actor holding one evaluator at a time, as a spawned worker process does: the
    evaluator of the run_episodes call whose episode it runs, built at its first (the previous one
    closed), its construction's error raised by each of the call's runs."""

    def __init__(self, worker: int):
        self.worker = worker
        self.call, self.evaluator, self.error = None, None, None

    def run(self, setup, situation, snapshot):
        """(the episode's EpisodeRecord, the id of the node it ran on); setup: (the call's number,
        make_evaluator, its arguments)."""
        call, make_evaluator, args = setup
        if call != self.call:
            self.close()
            self.call = call
            try:
                self.evaluator = make_evaluator(self.worker, *args)
            except Exception as error:
                self.error = error
        if self.error is not None:
            raise self.error
        return self.evaluator.run(situation, snapshot), ray.get_runtime_context().get_node_id()

    def close(self):
        if self.evaluator is not None:
            self.evaluator.close()
        self.evaluator, self.error = None, None
