"""Ctrl-C and SIGTERM for this workspace's nodes: a flag that the node's own loop checks.

rclpy's default handler shuts the context down from its own thread and then raises KeyboardInterrupt in
the main thread wherever that thread is, also inside a pybind11 call that is converting a message, where
it comes out as a RuntimeError ("Unable to convert call argument '0' to Python object"). A node stopped
that way exited 1 about once in 50 stops. With a flag, the callback that is running finishes, the loop
ends, and the node stops its drives, closes its files and shuts the context down itself, in order.
"""
from __future__ import annotations

import signal

import rclpy
from rclpy.signals import SignalHandlerOptions

POLL_S = 0.05  # the longest a stop waits for a blocked spin to return


class StopSignal:
    """Set by SIGINT or SIGTERM. With repeat_quits, a second signal raises KeyboardInterrupt: the user
    wants out now. A recorder passes False: it is writing what it has, and that is not to be cut short."""

    def __init__(self, repeat_quits: bool = True) -> None:
        self.requested = False
        self.repeat_quits = repeat_quits
        signal.signal(signal.SIGINT, self._handle)
        signal.signal(signal.SIGTERM, self._handle)

    def _handle(self, _signum, _frame) -> None:
        if self.requested and self.repeat_quits:
            raise KeyboardInterrupt
        self.requested = True


def init(args: list[str] | None = None, repeat_quits: bool = True) -> StopSignal:
    """rclpy.init without rclpy's signal handlers, and the flag that replaces them."""
    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    return StopSignal(repeat_quits)


def spin_until_stopped(executor, stop: StopSignal) -> None:
    while not stop.requested and rclpy.ok():
        executor.spin_once(timeout_sec=POLL_S)
