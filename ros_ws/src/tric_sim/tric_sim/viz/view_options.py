"""The live view of the in-process tools (tric-record, tric-eval, tric-demo): their --viz and
--viz-port options, and the Foxglove server they ask for (tric_sim.viz.foxglove_view), imported only
when asked, so that the options cost a tool nothing to offer."""

import sys


def add_view_arguments(parser) -> None:
    """--viz and --viz-port of the in-process tools (tric-record, tric-eval, tric-demo)."""
    parser.add_argument(
        "--viz",
        action="store_true",
        help="watch the run live in Foxglove: serve a Foxglove WebSocket on this machine",
    )
    parser.add_argument(
        "--viz-port", type=int, default=8765, help="TCP port of --viz's server (default 8765)"
    )


def open_view(args, prog: str):
    """The Foxglove view a tool's --viz asks for (tric_sim.viz.foxglove_view.FoxgloveView), or None
    (and nothing of foxglove imported) without --viz; ValueError when its port cannot be served."""
    if not args.viz:
        return None
    if not 0 < args.viz_port <= 65535:
        raise ValueError(f"--viz-port must be in [1, 65535], got {args.viz_port}")
    from tric_sim.viz.foxglove_view import FoxgloveView

    view = FoxgloveView(port=args.viz_port)
    print(
        f"{prog}: live view on {view.url} (Foxglove: Open connection > Foxglove WebSocket; "
        "layout: docs/foxglove_layout.json)",
        file=sys.stderr,
    )
    return view
