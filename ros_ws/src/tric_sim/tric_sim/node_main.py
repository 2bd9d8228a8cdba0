"""The body of every node executable's main(), as `ros2 run` runs it: build one node, spin it until
Ctrl-C (also one while it is being built) or an external shutdown, then destroy it. A node that
refuses its parameters (ValueError) ends the process with its message on one line and exit status 2;
otherwise the status is 0. The executor is made before the node, whose constructor announces it is
ready: a Ctrl-C right after that line finds the executor whole (one interrupted in its own
constructor leaves rclpy printing a traceback when it is collected)."""

import sys

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor


def run_node(node_class, prog: str, args=None) -> int:
    """Run node_class() under rclpy; prog names the executable in the error message."""
    rclpy.init(args=args)
    try:
        executor = SingleThreadedExecutor()
        node = node_class()
    except ValueError as error:
        print(f"{prog}: {error}", file=sys.stderr)
        rclpy.try_shutdown()
        return 2
    except KeyboardInterrupt:  # Ctrl-C while the node was being built
        rclpy.try_shutdown()
        return 0
    except Exception:
        if not rclpy.ok():  # Ctrl-C while the node was being built: rclpy shut its context down
            return 0
        raise
    try:
        executor.add_node(node)
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        node.destroy_node()
        rclpy.try_shutdown()
    return 0
