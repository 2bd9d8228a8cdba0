"""Evaluation episodes shared out over spawned worker processes (tric-eval --jobs, through the nodes
or offline): each worker builds its own evaluator once, with make_evaluator, and runs one episode
at a time on it; and calls (trainings) shared out likewise (calls_in_workers). Workers are spawned,
never forked: a forked process may hold rclpy's threads. This is the process executor of
tric_control.evaluation.executors; tric_control.evaluation.ray_executor runs the same contract on
Ray actors and tasks."""

import concurrent.futures
import multiprocessing

from tric_control.evaluation.records import EpisodeRecord, unjudged_fields
from tric_sim.tools.interrupts import end_workers_with_their_own

#: Seconds a starting worker process waits for its index.
WORKER_INDEX_TIMEOUT_S = 60.0
#: A worker process's evaluator, or the error that building it raised (re-raised by each of its
#: runs).
_worker: dict = {}


def run_in_workers(
    situations, snapshot, jobs: int, bar, make_evaluator, make_args, agent, on_record=None
) -> list:
    """evaluator.run(situation, snapshot) for every situation, in jobs spawned worker processes
    whose evaluators are make_evaluator(worker, *make_args()) (make_evaluator: a module-level
    function, so that it is picklable; worker: the process's index in [0, jobs) within its pool;
    make_args() is called for each pool); [EpisodeRecord] in the situations' order. bar (a tqdm bar)
    is advanced, and on_record(record) called (if given), as each episode ends. A worker that dies
    (a segfault, the OOM killer) breaks its pool: the episodes it took down are then run again, each
    alone in a pool of one worker, so that one whose worker dies again loses only itself: a failed
    record that says so (of the other records' agent, or of agent when none ended). Any other error
    cancels the episodes not started and is raised."""
    spawn = multiprocessing.get_context("spawn")
    records: list[EpisodeRecord | None] = [None] * len(situations)
    pending = list(range(len(situations)))
    ended = _ended(bar, on_record)
    pending = _run_pool(
        spawn, situations, pending, records, snapshot, jobs, ended, make_evaluator, make_args()
    )
    lost: list[int] = []
    for k in pending:
        lost += _run_pool(
            spawn, situations, [k], records, snapshot, 1, ended, make_evaluator, make_args()
        )
    agent = next((record.agent for record in records if record is not None), agent)
    for k in lost:
        records[k] = EpisodeRecord(
            **unjudged_fields(situations[k], agent),
            wall_time_s=0.0,
            outcome="failed",
            message="its evaluation worker process died, twice",
        )
        ended(situations[k], records[k])
    return records


def _ended(bar, on_record):
    """ended(situation, record): what follows each episode's end (the bar, on_record)."""

    def ended(situation, record):
        bar.set_postfix_str(situation.name)
        bar.update()
        if on_record is not None:
            on_record(record)

    return ended


def _run_pool(spawn, situations, pending, records, snapshot, jobs, ended, make_evaluator, args):
    """Run the pending episodes (indices into situations) in one pool, filling records (ended()
    after each); the indices its breaking (a worker that died) left without a record."""
    workers = spawn.Queue()
    for worker in range(jobs):
        workers.put(worker)
    with concurrent.futures.ProcessPoolExecutor(
        jobs, mp_context=spawn, initializer=_start_worker, initargs=(make_evaluator, workers, args)
    ) as pool:
        futures = {pool.submit(_run_in_worker, situations[k], snapshot): k for k in pending}
        try:
            for future in concurrent.futures.as_completed(futures):
                k = futures[future]
                try:
                    records[k] = future.result()
                except concurrent.futures.process.BrokenProcessPool:
                    continue
                ended(situations[k], records[k])
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)
            raise
    return [k for k in pending if records[k] is None]


def _start_worker(make_evaluator, workers, args):
    """Worker initializer: build this process's evaluator, with the next free index of workers (a
    queue); SIGTERM ends the worker's own workers with it (end_workers_with_their_own)."""
    end_workers_with_their_own()
    try:
        _worker["evaluator"] = make_evaluator(workers.get(timeout=WORKER_INDEX_TIMEOUT_S), *args)
    # an initializer's exception would only break the pool, without its message
    except Exception as error:
        _worker["error"] = error


def _run_in_worker(situation, snapshot):
    """One episode on this worker's evaluator; its construction's error, if it failed."""
    if "error" in _worker:
        raise _worker["error"]
    return _worker["evaluator"].run(situation, snapshot)


def calls_in_workers(function, calls: list, jobs: int, shared: tuple):
    """Yield (index, function(*shared, *calls[index]) or the Exception it raised) as each call
    ends, in up to jobs spawned worker processes, each given shared once (function: module-level).
    A worker that dies fails the calls it took down, each with an error that says so."""
    spawn = multiprocessing.get_context("spawn")
    with concurrent.futures.ProcessPoolExecutor(
        min(jobs, len(calls)), mp_context=spawn, initializer=_keep_shared, initargs=(shared,)
    ) as pool:
        futures = {
            pool.submit(_call_with_shared, function, call): k for k, call in enumerate(calls)
        }
        try:
            for future in concurrent.futures.as_completed(futures):
                try:
                    yield futures[future], future.result()
                except concurrent.futures.process.BrokenProcessPool:
                    yield futures[future], RuntimeError("its worker process died")
                except Exception as error:
                    yield futures[future], error
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)
            raise


def _keep_shared(shared: tuple) -> None:
    """Worker initializer of calls_in_workers: keep the calls' shared arguments; SIGTERM ends the
    worker's own workers with it (end_workers_with_their_own)."""
    end_workers_with_their_own()
    _worker["shared"] = shared


def _call_with_shared(function, call):
    return function(*_worker["shared"], *call)
