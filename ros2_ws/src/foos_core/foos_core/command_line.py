"""What the project's image commands (render_video, track_video, ...) do alike: one-line errors, non-zero
exits, single-threaded OpenCV."""
from __future__ import annotations

import argparse
import os
import sys
from typing import Callable

import cv2


def quiet_threads() -> None:
    """The table's CPUs are shared: one OpenCV thread, as the benchmark measures it."""
    cv2.setNumThreads(1)
    os.environ.setdefault("OMP_NUM_THREADS", "1")


def run_cli(parser: argparse.ArgumentParser, body: Callable[[argparse.Namespace], int], argv=None) -> None:
    """Run a command: its body on the arguments parsed; bad input ends in one line on stderr and exit status 2
    (1 for failures), named by the parser's prog."""
    args = parser.parse_args(argv)
    prog = parser.prog
    quiet_threads()
    try:
        code = body(args)
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        code = 130
    except (ValueError, OSError) as error:  # every package's bad-input errors are ValueErrors
        message = str(error).strip().splitlines()[0] if str(error).strip() else type(error).__name__
        print(f"{prog}: error: {message}", file=sys.stderr)
        code = 2
    except Exception as error:  # a library's own error type (foos_sim.ParamsError, foos_bag.BagError, ...)
        text = str(error).strip().splitlines()
        print(f"{prog}: error: {type(error).__name__}: {text[0] if text else ''}", file=sys.stderr)
        code = 1
    sys.exit(code)
