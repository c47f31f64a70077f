"""Commands that moved out of foos_sim: each says where it went, then runs there with the same arguments.

`calibrate` and `generate_measured` judge the simulator rather than simulate, and live in foos_calibration
since the packages were re-layered. This runs the moved executable by path rather than importing it, so
foos_sim does not import the package above it.
"""
from __future__ import annotations

import os
import sys

from ament_index_python.packages import PackageNotFoundError, get_package_prefix


def _forward(package: str, executable: str) -> None:
    print(f"note: `ros2 run foos_sim {executable}` has moved to `ros2 run {package} {executable}`", file=sys.stderr)
    try:
        path = os.path.join(get_package_prefix(package), "lib", package, executable)
    except PackageNotFoundError:
        print(f"{executable}: error: package {package} is not installed (source scripts/env.sh)", file=sys.stderr)
        sys.exit(1)
    os.execv(path, [path, *sys.argv[1:]])


def calibrate() -> None:
    _forward("foos_calibration", "calibrate")


def generate_measured() -> None:
    _forward("foos_calibration", "generate_measured")
