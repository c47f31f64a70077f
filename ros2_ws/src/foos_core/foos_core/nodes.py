"""One `main()` for every node of the workspace: start, spin until Ctrl-C or SIGTERM, stop in order.

    def main(args=None) -> int:
        return run_node("policy_node", PolicyNode, errors=(PolicyError, ValueError), on_exit=PolicyNode.stop_rods)

A bad parameter or input is one line on stderr, `NAME: error: ...`, and exit code 2 (or the code the
`errors` mapping gives); Ctrl-C is exit 0. The node finishes the callback it is in, `on_exit` runs while
the context is still up (a last command can still go out), then the node is destroyed and the context
shut down (see node_signals for why rclpy's own signal handler is not used).
"""
from __future__ import annotations

import sys
from typing import Callable, Mapping, Sequence, Union

import rclpy
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.node import Node

from . import node_signals

ErrorCodes = Union[Sequence[type], Mapping[type, int]]


def _spin(_node: Node, executor: Executor, stop: node_signals.StopSignal) -> None:
    node_signals.spin_until_stopped(executor, stop)


def run_node(
    name: str,
    make_node: Callable[[], Node],
    *,
    run: Callable[[Node, Executor, node_signals.StopSignal], None] = _spin,
    errors: ErrorCodes = (ValueError,),
    on_exit: Callable[[Node], None] | None = None,
    make_executor: Callable[[], Executor] = SingleThreadedExecutor,
    args: list[str] | None = None,
    repeat_quits: bool = True,
) -> int:
    """Run one node until it is stopped; returns the process's exit code.

    make_node builds the node after rclpy is initialised; run drives it (by default, spin until the stop
    flag is set); errors are the exceptions that mean bad input, a sequence (exit 2) or a mapping from
    exception type to exit code; on_exit runs before the node is destroyed, whatever happened;
    repeat_quits=False makes a second Ctrl-C wait for the node too (a recorder writing what it has).
    """
    codes = dict(errors) if isinstance(errors, Mapping) else {error: 2 for error in errors}
    stop = node_signals.init(args, repeat_quits)
    node = None
    try:
        node = make_node()
        executor = make_executor()
        executor.add_node(node)
        run(node, executor, stop)
    except KeyboardInterrupt:  # a second Ctrl-C
        pass
    except tuple(codes) as error:
        code = next(c for kind, c in codes.items() if isinstance(error, kind))
        print(f"{name}: error: {str(error).splitlines()[0] if str(error) else type(error).__name__}", file=sys.stderr)
        return code
    finally:
        if node is not None:
            if on_exit is not None:
                on_exit(node)
            node.destroy_node()
        rclpy.try_shutdown()
    return 0
