"""How the tools end when interrupted: SIGINT (Ctrl-C) or SIGTERM, at any moment, ends a tool with
one line on stderr and exit status 130 or 143 (128 + the signal's number, as a shell reports a
process the signal ended), leaving every finished file complete and nothing unfinished under a
final name.

Run as a command (end_commands_on_signals), the tool ends at once from the signal handler: its
worker processes are ended, the temporary files of writes in progress removed
(tric_sim.tools.output_files), and the process exits without tearing its ROS nodes down one by one
(destroying nodes under their running threads crashed rclpy: a segmentation fault in 1 of 3
interrupted tric-eval runs). Every result is written atomically and a bag is recorded as .part
until complete, so nothing else needs finishing. Called in-process (tests, scripts),
run_interruptible turns the signals into KeyboardInterrupt and the tool's own cleanup runs.
"""

import importlib
import multiprocessing
import os
import signal
import sys
import threading

from tric_sim.tools.output_files import remove_temporaries


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
    progress = sys.modules.get("tqdm")
    bars_open = progress is not None and len(getattr(progress.tqdm, "_instances", ())) > 0
    print(("\n" if bars_open else "") + line(prog, signum, kept), file=sys.stderr, flush=True)


def end_at_once(prog: str, signum: int, kept: str = "") -> None:
    """End the process now as signum ends a command: its worker processes ended, the temporary
    files of writes in progress removed, the line printed, exit status 128 + signum."""
    for child in multiprocessing.active_children():
        child.terminate()
    remove_temporaries()
    sys.stdout.flush()
    _print_line(prog, signum, kept)
    os._exit(exit_status(signum))


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


def node_main(prog: str, module: str) -> int:
    """A node's entry point (`ros2 run PKG NODE`): SIGINT and SIGTERM end it as they end a command
    from its first instant, its module's imports included (torch and rclpy take seconds, and
    rclpy's handlers are not installed yet); then module's main() runs the node, which installs
    its own (tric_sim.ros.graph.run_node)."""
    end_commands_on_signals(prog)
    return importlib.import_module(module).main()
