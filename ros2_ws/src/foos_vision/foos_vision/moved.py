"""Commands that moved out of foos_vision: each says where it went, then runs there with the same arguments.

`render_video` films the simulated table, which is the simulator's job: it lives in foos_sim.camera since
the synthetic camera moved below the tracker.
"""
from __future__ import annotations

import sys

from foos_sim.camera import render_cli


def render_video() -> None:
    print("note: `ros2 run foos_vision render_video` has moved to `ros2 run foos_sim render_video`", file=sys.stderr)
    render_cli.main()
