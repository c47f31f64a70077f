"""Where a figure can show up in the ball plane: one band of y per rod (used by the `auto` colour vote).

A figure is fixed to its rod: it slides along x and turns about the rod's axis, but its y never leaves the
rod's line. The tracker maps every pixel onto the ball-centre plane, so a figure's pixels, which lie higher
than the ball's centre, land farther from the camera's foot than the figure is (parallax), but always at
the same y whatever the rod's slide: for a point at height z and table y, seen from a camera at C, the ray
meets the ball plane at y_b = C_y + (y - C_y) (C_z - z_b) / (C_z - z), which does not depend on x. So a
figure sliding with its rod draws a line of constant y_b inside its rod's band, while a ball rolls in two
dimensions and crosses the rod lines. The figures' sizes and rod positions are foos_sim's (the regulation
table, or a calibrated table's parameter file).

ROS-free: plain numpy.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from .markers import BALL_CENTRE_HEIGHT


@dataclass(frozen=True)
class RodGeometry:
    """What decides where a hanging figure can be seen: rod lines and a figure's extent (table frame, m)."""

    rod_y: tuple[float, ...]  # y of each rod's axis
    top: float  # height of a figure's head (rod axis + head height)
    half_thickness: float  # half the figure's extent along y (its foot, the thickest part)


def rod_geometry(params_file: Optional[str] = None) -> RodGeometry:
    """The rods and figures of foos_sim's table (the nominal one when params_file is None)."""
    from foos_sim.table_params import load_params

    tree = load_params(params_file)
    rods, figure = tree["rods"], tree["figure"]
    return RodGeometry(rod_y=tuple(sorted(float(r["y"]) for r in rods["layout"].values())),
                       top=float(rods["axis_height"]) + float(figure["head_height"]),
                       half_thickness=max(float(figure["foot_size"][1]), float(figure["body_size"][1])) / 2)


def camera_centre(projection: np.ndarray) -> np.ndarray:
    """The camera's position (table frame) from its 3x4 projection matrix: the matrix's null vector."""
    _, _, vt = np.linalg.svd(projection)
    centre = vt[-1]
    return centre[:3] / centre[3]


def rod_bands(geometry: RodGeometry, centre: np.ndarray, margin: float = 0.005) -> np.ndarray:
    """(rods, 2) interval of ball-plane y that a hanging figure of each rod covers in this camera's view: the
    parallax of every height from the floor to the head, for the figure's front and back faces, plus margin."""
    cy, cz = float(centre[1]), float(centre[2])
    bands = []
    for y in geometry.rod_y:
        ends = [cy + (face - cy) * (cz - BALL_CENTRE_HEIGHT) / (cz - z)
                for face in (y - geometry.half_thickness, y + geometry.half_thickness) for z in (0.0, geometry.top)]
        bands.append((min(ends) - margin, max(ends) + margin))
    return np.array(bands)


def on_rod_line(y: float, bands: np.ndarray) -> bool:
    return bool(np.any((bands[:, 0] <= y) & (y <= bands[:, 1])))

