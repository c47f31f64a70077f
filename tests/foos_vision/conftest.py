"""Fixtures of the vision tests: short rendered videos shared by the tests of a session."""
from __future__ import annotations

import pytest

from .drawn_table import write_layout
from .helpers import render


@pytest.fixture(scope="session")
def layout(tmp_path_factory):
    """The markers of the drawn table (drawn_table: real ArUco tags, straight down); a test module drawing its
    table at another scale has its own."""
    return write_layout(tmp_path_factory.mktemp("drawn") / "markers.yaml")


@pytest.fixture(scope="session")
def overhead_video(tmp_path_factory):
    """1.2 s overhead 640x480 @ 60 fps, yellow ball, rods kicking, ball picked up for 0.3 s."""
    out = tmp_path_factory.mktemp("vision") / "overhead.mp4"
    return render(out, "--camera", "overhead", "--fps", "60", "--duration", "1.2", "--ball-color", "yellow",
                  "--hide-every", "0.6", "--hide-for", "0.3", "--visibility", "--seed", "3")
