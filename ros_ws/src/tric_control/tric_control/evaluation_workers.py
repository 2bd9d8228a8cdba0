"""Evaluation episodes shared out over spawned worker processes (tric-eval --jobs, through the nodes
or offline): each worker builds its own evaluator once, with make_evaluator, and runs one episode
at a time on it. Workers are spawned, never forked: a forked process may hold rclpy's threads."""

import concurrent.futures
import multiprocessing

#: A worker process's evaluator, or the error that building it raised (re-raised by each of its
#: runs).
_worker = {}


def run_in_workers(situations, snapshot, jobs: int, bar, make_evaluator, args: tuple) -> list:
    """evaluator.run(situation, snapshot) for every situation, in jobs spawned worker processes
    whose evaluators are make_evaluator(*args) (make_evaluator: a module-level function, so that
    it is picklable); [EpisodeRecord] in the situations' order. bar (a tqdm bar) is advanced as
    each episode ends. On an error the episodes not started are canceled and the error raised."""
    spawn = multiprocessing.get_context("spawn")
    records = [None] * len(situations)
    with concurrent.futures.ProcessPoolExecutor(
        jobs,
        mp_context=spawn,
        initializer=_start_worker,
        initargs=(make_evaluator, args),
    ) as pool:
        futures = {
            pool.submit(_run_in_worker, situation, snapshot): k
            for k, situation in enumerate(situations)
        }
        try:
            for future in concurrent.futures.as_completed(futures):
                records[futures[future]] = future.result()
                bar.set_postfix_str(situations[futures[future]].name)
                bar.update()
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)
            raise
    return records


def _start_worker(make_evaluator, args):
    """Worker initializer: build this process's evaluator."""
    try:
        _worker["evaluator"] = make_evaluator(*args)
    # an initializer's exception would only break the pool, without its message
    except Exception as error:
        _worker["error"] = error


def _run_in_worker(situation, snapshot):
    """One episode on this worker's evaluator; its construction's error, if it failed."""
    if "error" in _worker:
        raise _worker["error"]
    return _worker["evaluator"].run(situation, snapshot)
