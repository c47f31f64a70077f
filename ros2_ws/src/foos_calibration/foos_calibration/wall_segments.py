"""Restitution per stretch of wall: a generic check for a soft or lively piece of wall the vocabulary cannot place.

`wall_restitution` names one coefficient for every wall (or one per wall). A loose board or a worn
cushion makes one stretch of one wall bounce differently. This check reuses the bounce windows' MuJoCo
replay errors (bounces.fit_restitution: every window replayed at every restitution of the grid), groups
the windows by where they hit (each wall whole, each side wall in thirds along y, each end wall in its
halves beside the goal), and fits each stretch's own coefficient.

It names no cause. A stretch is reported under `unexplained` only where its coefficient, fitted on one fold
of its bounces, lowers the replay error of the other fold's bounces (the effect_gain rule: a 95 % bootstrap
interval of the drop that excludes zero), and both folds put it at least bounces.MIN_CHANGE from the
table's coefficient on the same side.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from foos_core.table_geometry import TableGeometry

from .bounces import MIN_CHANGE, RestitutionResult, held_out_replay_gain, spline_minimum
from .effect_gain import excludes_zero

MIN_BOUNCES = 6  # bounces a stretch needs, three a fold


@dataclass
class Stretch:
    wall: str
    start: float  # m along the wall (y for a side wall, x for an end wall)
    end: float

    def describe(self) -> str:
        axis = "y" if self.wall.startswith("side") else "x"
        return f"{self.wall} between {axis} {self.start:+.2f} and {self.end:+.2f} m"


def stretches(geometry: TableGeometry) -> list[Stretch]:
    """Each wall whole, then its thirds (side walls) or halves beside the goal (end walls)."""
    third = 2 * geometry.half_length / 3
    out = [Stretch(wall, -geometry.half_length, geometry.half_length) for wall in ("side_neg_x", "side_pos_x")]
    out += [Stretch(wall, -geometry.half_width, geometry.half_width) for wall in ("end_home", "end_away")]
    out += [Stretch(wall, -geometry.half_length + k * third, -geometry.half_length + (k + 1) * third)
            for wall in ("side_neg_x", "side_pos_x") for k in range(3)]
    out += [Stretch(wall, lo, hi) for wall in ("end_home", "end_away")
            for lo, hi in ((-geometry.half_width, 0.0), (0.0, geometry.half_width))]
    return out


def _hit_point(window, geometry: TableGeometry) -> float:
    """Where along its wall a window's bounce hit: the detection nearest the wall."""
    if window.wall.startswith("side"):
        k = int(np.argmax(np.abs(window.xy[:, 0])))
        return float(window.xy[k, 1])
    k = int(np.argmax(np.abs(window.xy[:, 1])))
    return float(window.xy[k, 0])


def check_stretches(result: RestitutionResult, table_e: float, geometry: TableGeometry, seed: int = 0) -> list[dict]:
    """Each stretch with enough bounces: its fitted coefficient, its held-out gain, and whether it is reported."""
    if not result.windows:
        return []
    along = np.array([_hit_point(w, geometry) for w in result.windows])
    out = []
    for stretch in stretches(geometry):
        rows = np.flatnonzero([(w.wall == stretch.wall) and stretch.start <= a <= stretch.end
                               for w, a in zip(result.windows, along)])
        if len(rows) < MIN_BOUNCES:
            continue
        rss = result.rss[rows]
        fold_e, gain = held_out_replay_gain([result.windows[i] for i in rows], rss, np.arange(len(rows)) % 2, table_e, seed)
        fitted = spline_minimum(rss.sum(axis=0))
        same_side = all(abs(e - table_e) >= MIN_CHANGE and np.sign(e - table_e) == np.sign(fitted - table_e) for e in fold_e)
        out.append({"stretch": stretch.describe(), "wall": stretch.wall, "from_m": round(stretch.start, 3),
                    "to_m": round(stretch.end, 3), "bounces": int(len(rows)), "coefficient": round(fitted, 3),
                    "fold_coefficients": [round(e, 3) for e in fold_e], "table_coefficient": round(table_e, 3),
                    "gain": gain, "reported": bool(excludes_zero(gain) and same_side)})
    return out


def unexplained_entries(checked: list[dict], noise: float) -> list[dict]:
    """The reported stretches as `unexplained` places: where, how much, and the gain."""
    entries = []
    for c in checked:
        if not c["reported"]:
            continue
        g = c["gain"]
        entries.append({
            "where": f"the wall {c['stretch']}: bounces back at {c['coefficient']:.2f}, the table's walls at "
                     f"{c['table_coefficient']:.2f} ({c['bounces']} bounces)",
            "kind": "wall_stretch_restitution", "residual_mm": g["without"], "noise_mm": round(noise * 1000, 2),
            "ratio": round(g["without"] / (noise * 1000), 2) if noise > 0 and g["without"] is not None else None,
            "coefficient": c["coefficient"], "wall": c["wall"], "from_m": c["from_m"], "to_m": c["to_m"],
            "gain": {"bounce_replay_error_mm": g},
            "cause": "not named: a stretch of wall bounces differently; why (a loose board, a worn cushion) is not proven",
        })
    return entries
