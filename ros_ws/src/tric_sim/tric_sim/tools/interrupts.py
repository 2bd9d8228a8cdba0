"""How the tools end when interrupted: SIGINT (Ctrl-C) or SIGTERM, at any moment, ends a tool with
one line on stderr and exit status 130 or 143 (128 + the signal's number, as a shell reports a
process the signal ended), leaving every finished file complete and nothing unfinished under a
final name.

Run as a command (end_commands_on_signals), the tool ends at once from the signal handler: its
worker processes are ended (each of them ending its own first: end_workers_with_their_own), the
temporary files of writes in progress and its lock files removed (tric_sim.tools.output_files,
tric_sim.tools.claims), the named semaphores of its process pools
unlinked (so that multiprocessing's resource tracker has nothing left to warn about), and the
process exits without tearing its ROS nodes down one by one (destroying nodes under their running
threads crashed rclpy: a segmentation fault in 1 of 3 interrupted tric-eval runs). Every result is
written atomically and a bag is recorded as .part until complete, so nothing else needs finishing.
Called in-process (tests, scripts), run_interruptible turns the signals into KeyboardInterrupt and
the tool's own cleanup runs.

The entry points of the commands and nodes (command_main, node_main) install this handling before
they import anything (this module imports no more than signal, threading and importlib), so that a
signal during the imports (torch, rclpy and pybullet take a second or more) ends a tool the same
way. Only what Python does before the entry point runs (its start-up and the console script's
look-up of the entry point, some 40 ms) is left to Python's own handling.
"""

import importlib
import os
import signal
import sys
import threading


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where SIGINT raises KeyboardInterrupt."""


def _raise_terminated(signum, frame):
    raise Terminated()


def exit_status(signum: int) -> int:
    """The exit status of a tool a signal ended: 128 + the signal's number."""
    return 128 + signum


def line(prog: str, signum: int, kept: str = "") -> str:
    """A tool's one line when signum ends it, with what it kept."""
    word = "terminated" if signum == signal.SIGTERM else "interrupted"
    return f"{prog}: {word}" + (f"; {kept}" if kept else "")


def _print_line(prog: str, signum: int, kept: str) -> None:
    """The tool's line on stderr, on a line of its own: a progress bar (tqdm) draws without a
    newline, so one ends the bar's line first while a bar is open."""
    bars = getattr(sys.modules.get("tqdm"), "tqdm", None)  # None: not imported (or not yet whole)
    bars_open = len(getattr(bars, "_instances", ())) > 0
    print(("\n" if bars_open else "") + line(prog, signum, kept), file=sys.stderr, flush=True)


def end_at_once(prog: str, signum: int, kept: str = "") -> None:
    """End the process now as signum ends a command: its worker processes ended, the temporary
    files of writes in progress and its lock files removed, its semaphores unlinked, the line
    printed, exit status 128 + signum. The cleaning up is done as far as it can be: the signal may
    come in the middle of any import, with modules not yet whole, and nothing it meets there may
    keep the tool from its line and its end."""
    _clean_up()
    try:
        sys.stdout.flush()
    except (OSError, ValueError):  # stdout closed, or a pipe whose reader left
        pass
    _print_line(prog, signum, kept)
    os._exit(exit_status(signum))


def _clean_up() -> None:
    """End the worker processes, remove the temporary and lock files, unlink the semaphores; the
    modules that hold them are looked up, not imported (one not imported yet holds nothing). Done
    as far as it can be: nothing it meets may keep the process from its end."""
    try:
        multiprocessing = sys.modules.get("multiprocessing")
        for child in multiprocessing.active_children() if multiprocessing else ():
            child.terminate()
        for module, cleanup in (
            ("tric_sim.tools.output_files", "remove_temporaries"),
            ("tric_sim.tools.claims", "remove_lock_files"),
        ):
            getattr(sys.modules.get(module), cleanup, lambda: None)()
        _unlink_semaphores()
    except Exception:  # a module caught half imported: what it holds is not worth a traceback
        pass


def _unlink_semaphores() -> None:
    """Unlink the named semaphores of this process's multiprocessing objects (queues, locks,
    process pools) and tell the resource tracker, as their finalizers do at a normal exit; left to
    the tracker, each is one "leaked semaphore" warning after the tool's line. Skipped while the
    tracker's lock is held (the signal came while it started: it then warns, and unlinks them)."""
    synchronize = sys.modules.get("multiprocessing.synchronize")
    util = sys.modules.get("multiprocessing.util")
    tracker = sys.modules.get("multiprocessing.resource_tracker")
    if synchronize is None or util is None or tracker is None:
        return
    lock = tracker._resource_tracker._lock  # an RLock: this thread may hold it already
    if not lock.acquire(blocking=False):
        return
    held_before = getattr(lock, "_recursion_count", lambda: 1)() > 1
    lock.release()
    if held_before:
        return
    for finalizer in list(util._finalizer_registry.values()):
        if getattr(finalizer, "_callback", None) is synchronize.SemLock._cleanup:
            try:
                finalizer()
            except OSError:  # unlinked already
                pass


def end_workers_with_their_own() -> None:
    """In a tool's worker process: SIGTERM, with which the tool ends its workers (end_at_once), ends
    this worker's own worker processes first (a training's forked sampling workers, which were left
    running, orphaned, when only their parent ended), removes its temporary and lock files, and
    ends it with status 143 and no line (the tool prints its own)."""

    def end(signum, frame):
        _clean_up()
        os._exit(exit_status(signum))

    signal.signal(signal.SIGTERM, end)


def end_commands_on_signals(prog: str, kept: str = "") -> None:
    """As a command: SIGINT and SIGTERM end the process at once (see the module docstring)."""

    def end(signum, frame):
        end_at_once(prog, signum, kept)

    signal.signal(signal.SIGINT, end)
    signal.signal(signal.SIGTERM, end)


def run_interruptible(prog: str, body, argv, kept: str = "") -> int:
    """body(argv)'s exit status. argv None (a command): end_commands_on_signals first. Otherwise
    (in-process) SIGTERM raises Terminated meanwhile (the earlier handler restored after), and
    when SIGINT or SIGTERM ends body, the tool's line is printed and its status returned. Off the
    main thread, where no signal arrives, just body(argv)."""
    if threading.current_thread() is not threading.main_thread():
        return body(argv)
    if argv is None:
        end_commands_on_signals(prog, kept)
        return body(argv)
    previous = signal.signal(signal.SIGTERM, _raise_terminated)
    try:
        return body(argv)
    except KeyboardInterrupt as interrupt:
        signum = signal.SIGTERM if isinstance(interrupt, Terminated) else signal.SIGINT
        _print_line(prog, signum, kept)
        return exit_status(signum)
    finally:
        signal.signal(signal.SIGTERM, previous)


def command_main(prog: str, module: str) -> int:
    """A command-line tool's entry point (`ros2 run PKG TOOL`): SIGINT and SIGTERM end it with its
    one line from before its module is imported (its imports included); then module's main() runs
    the tool, which says what it keeps when interrupted (run_interruptible)."""
    end_commands_on_signals(prog)
    return importlib.import_module(module).main()


def node_main(prog: str, module: str) -> int:
    """A node's entry point (`ros2 run PKG NODE`): SIGINT and SIGTERM end it as they end a command
    from its first instant, its module's imports included (torch and rclpy take seconds, and
    rclpy's handlers are not installed yet); then module's main() runs the node, which installs
    its own (tric_sim.ros.graph.run_node). Arguments before --ros-args: -h or --help prints the
    node's description (its module's docstring, read without importing it) and exits 0; any other
    is refused with one line and exit status 2 (the node takes only ROS arguments)."""
    end_commands_on_signals(prog)
    own = sys.argv[1 : sys.argv.index("--ros-args")] if "--ros-args" in sys.argv else sys.argv[1:]
    if "-h" in own or "--help" in own:
        print(node_help(prog, module))
        return 0
    if own:
        print(
            f"{prog}: unknown argument {own[0][:80]!r} (a node takes ROS arguments only: "
            "--ros-args -p NAME:=VALUE ...; --help describes it)",
            file=sys.stderr,
        )
        return 2
    return importlib.import_module(module).main()


def node_help(prog: str, module: str) -> str:
    """A node's --help: how it starts, and its module's docstring (its topics, services and
    parameters), read from the source without importing it."""
    import ast
    import importlib.util
    import pathlib

    spec = importlib.util.find_spec(module)
    origin = spec.origin if spec is not None else None
    docstring = ast.get_docstring(ast.parse(pathlib.Path(origin).read_bytes())) if origin else None
    package = module.split(".")[0]
    usage = f"usage: ros2 run {package} {prog} [--ros-args -p NAME:=VALUE ...]"
    return f"{usage}\n\n{docstring or ''}".rstrip()
