"""A table that is not the regulation one, given only its field size (`track_video --field-size`,
shared/CONTRACT.md): a 1.12 x 0.64 m table, whose regulation layout the parameter validator refuses, is
rendered and tracked from its field corners; bad sizes are one-line errors."""
from __future__ import annotations

import numpy as np
import pytest

from foos_core.field_size import parse_field_size, with_field_size, write_field_sized
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import ParamsError, load_params, validate

from .helpers import render, ros2_run
from .test_field_corners import clicked, field_corner_pixels, rendered_camera, track_errors
from .test_track_video import one_line_error

LENGTH, WIDTH = 1.12, 0.64


def test_the_regulation_layout_does_not_fit_a_narrower_table_but_the_resized_one_does():
    nominal = load_params()
    squeezed = {**nominal, "field": {**nominal["field"], "length": LENGTH, "width": WIDTH}}
    with pytest.raises(ParamsError, match="side wall"):
        validate(squeezed)
    resized = with_field_size(nominal, LENGTH, WIDTH)
    assert (resized["field"]["length"], resized["field"]["width"]) == (LENGTH, WIDTH)
    home_goalie = resized["rods"]["layout"]["home_goalie"]
    assert home_goalie["y"] == pytest.approx(-0.525 * LENGTH / 1.2)
    assert resized["rods"]["layout"]["home_midfield"]["spacing"] == pytest.approx(0.12 * WIDTH / 0.68)
    assert nominal["field"]["length"] == 1.2  # the tree given is not changed


@pytest.mark.parametrize("text, reason", [
    ("1.12", "is not LENGTH,WIDTH"), ("1.12,0.64,0.1", "is not LENGTH,WIDTH"), ("112,64", "metres, not cm"),
    ("0.64,1.12", "comes first"), ("1.12,nan", "outside"),
])
def test_a_bad_field_size_is_refused(text, reason):
    with pytest.raises(ParamsError, match=reason):
        parse_field_size(text)


@pytest.mark.timeout(300)
def test_track_video_needs_only_the_field_size_of_a_smaller_table(tmp_path):
    table = write_field_sized(None, LENGTH, WIDTH, tmp_path / "small_table.yaml")
    video = render(tmp_path / "small.mp4", "--camera", "overhead", "--fps", "60", "--duration", "1.2",
                   "--ball-color", "yellow", "--hide-every", "0.6", "--hide-for", "0.3", "--visibility",
                   "--seed", "3", "--params-file", str(table))
    corners = field_corner_pixels(rendered_camera(video), TableGeometry.of(table))
    result = ros2_run("track_video", str(video), "--field-corners", clicked(corners, seed=5), "--field-size",
                      f"{LENGTH},{WIDTH}", "--out", str(tmp_path / "bag"), "--quiet", timeout=240)
    assert result.returncode == 0, result.stderr
    error, frames, half_visible, while_hidden = track_errors(video, tmp_path / "bag")
    assert while_hidden == 0
    assert len(np.intersect1d(frames, half_visible)) >= 0.9 * len(half_visible)
    assert np.median(error) < 0.003, f"median {np.median(error) * 1000:.2f} mm"


def test_track_video_refuses_a_bad_field_size_in_one_line(overhead_video, tmp_path):
    result = ros2_run("track_video", str(overhead_video), "--field-corners", "136,136,136,343,502,343,502,136",
                      "--field-size", "112,64", "--out", str(tmp_path / "bag"))
    assert result.returncode == 2
    one_line_error(result, "metres, not cm")
    assert not (tmp_path / "bag").exists()
