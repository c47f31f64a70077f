"""The markers file: ArUco tags placed in the table frame (see CONTRACT.md, "Markers and video time")."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from .table_geometry import TableGeometry
from .yaml_files import read_mapping

# The simulated camera's tags (foos_sim.camera draws them), which tracker_node knows by default.
DEFAULT_MARKERS_FILE = Path(__file__).resolve().parent / "params" / "markers.yaml"


class MarkersError(ValueError):
    """A markers file that is missing, malformed, or does not match the tags in the video (one line)."""
# m, the plane the tracker reports the ball in: the regulation ball's centre (CONTRACT.md, "Markers and video time")
BALL_CENTRE_HEIGHT = TableGeometry.nominal().ball_centre_height


@dataclass(frozen=True)
class MarkerLayout:
    dictionary: str
    size: float
    positions: dict[int, np.ndarray]  # id -> (x, y, z) of the tag centre

    def aruco_dictionary(self):
        return cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))

    @property
    def ids(self) -> list[int]:
        return sorted(self.positions)

    def plane_height(self) -> float | None:
        """The common height of all tags, or None when they are not coplanar (to 1 mm)."""
        z = np.array([p[2] for p in self.positions.values()])
        return float(z.mean()) if np.ptp(z) < 1e-3 else None


def load_markers(path: str | Path | None = None) -> MarkerLayout:
    path = Path(path) if path is not None else DEFAULT_MARKERS_FILE
    if not path.is_file():
        raise MarkersError(f"markers file not found: {path}")
    tree = read_mapping(path, "markers file", MarkersError)
    if "markers" not in tree:
        raise MarkersError(f"{path}: a markers file is a mapping with `markers: {{id: [x, y, z]}}`")
    dictionary = str(tree.get("dictionary", "DICT_4X4_50"))
    if not dictionary.startswith("DICT_") or not hasattr(cv2.aruco, dictionary):
        raise MarkersError(f"{path}: unknown ArUco dictionary `{dictionary}` (e.g. DICT_4X4_50)")
    try:
        size = float(tree.get("size", 0.06))
    except (TypeError, ValueError):
        raise MarkersError(f"{path}: `size` must be a number (tag edge in m)") from None
    if not np.isfinite(size) or size <= 0:
        raise MarkersError(f"{path}: `size` must be a positive number of metres")
    markers = tree["markers"]
    if not isinstance(markers, dict) or not markers:
        raise MarkersError(f"{path}: `markers` must map tag ids to [x, y, z]")
    positions: dict[int, np.ndarray] = {}
    for key, value in markers.items():
        try:
            tag_id = int(key)
            xyz = np.asarray(value, float).ravel()
        except (TypeError, ValueError):
            raise MarkersError(f"{path}: marker `{key}` must be an integer id with [x, y, z]") from None
        if xyz.size != 3 or not np.all(np.isfinite(xyz)):
            raise MarkersError(f"{path}: marker {key} needs three finite numbers [x, y, z], got {value!r}")
        if np.any(np.abs(xyz) > 10):
            raise MarkersError(f"{path}: marker {key} at {value} is not in metres")
        positions[tag_id] = xyz
    if len(positions) < 4:
        raise MarkersError(f"{path}: at least 4 tags are needed for a homography, the file places {len(positions)}")
    xy = np.array([p[:2] for p in positions.values()])
    if np.linalg.matrix_rank(xy - xy.mean(axis=0), tol=1e-3) < 2:
        raise MarkersError(f"{path}: the tags are on one line; a homography needs them spread over the table")
    return MarkerLayout(dictionary, size, positions)
