"""The table's dimensions as the packages above read them, from the one parameter file.

    geometry = TableGeometry.from_params(load_params(params_file))   # or TableGeometry.nominal()
    geometry.half_width, geometry.half_length, geometry.rod_y[("home", "attack")]

Nothing else types a dimension of the table: a non-regulation table is another parameter file.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path

from .table_params import load_params


@dataclass(frozen=True)
class TableGeometry:
    half_width: float        # m, x of the inner side-wall faces
    half_length: float       # m, y of the inner end-wall faces (the goal lines)
    goal_half_width: float   # m, half the goal mouth, centred at x = 0
    goal_depth: float        # m, the pocket behind each goal line
    ball_radius: float       # m; the ball's centre rolls this high above the surface
    rod_y: dict = field(default_factory=dict)  # (team, rod) -> y of the rod's axis, m

    @classmethod
    def from_params(cls, params: dict) -> "TableGeometry":
        field_ = params["field"]
        layout = params["rods"]["layout"]
        rods = {}
        for key, rod in layout.items():
            team, name = key.split("_", 1)  # layout keys are rod_name(team, rod)
            rods[(team, name)] = float(rod["y"])
        return cls(half_width=float(field_["width"]) / 2, half_length=float(field_["length"]) / 2,
                   goal_half_width=float(field_["goal_width"]) / 2, goal_depth=float(field_["goal_depth"]),
                   ball_radius=float(params["ball"]["radius"]), rod_y=rods)

    @classmethod
    def nominal(cls) -> "TableGeometry":
        return _nominal()

    @classmethod
    def of(cls, params_file: str | Path | None = None) -> "TableGeometry":
        """The geometry a parameter file describes (the regulation table for None)."""
        return _nominal() if params_file is None else cls.from_params(load_params(params_file))

    @property
    def ball_centre_height(self) -> float:
        return self.ball_radius


@lru_cache(maxsize=1)
def _nominal() -> TableGeometry:
    return TableGeometry.from_params(load_params())
