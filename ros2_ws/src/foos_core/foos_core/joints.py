"""Putting joint arrays into the contract's order by name (/joint_states may list joints in any order)."""
from __future__ import annotations

from typing import Sequence

import numpy as np

from .names import JOINT_NAMES


class MissingJointsError(ValueError):
    """A joint list lacks joints that are needed."""


def joint_order(names: Sequence[str], wanted: Sequence[str] = JOINT_NAMES, allow_missing: bool = False) -> np.ndarray:
    """Index into `names` of each wanted joint, in `wanted`'s order: `values[joint_order(names)]` puts a
    message's values into JOINT_NAMES order. A joint missing from `names` is -1 with allow_missing, else
    MissingJointsError names the missing ones."""
    index = {name: i for i, name in enumerate(names)}
    missing = [name for name in wanted if name not in index]
    if missing and not allow_missing:
        raise MissingJointsError(f"missing joints: {', '.join(missing)}")
    return np.array([index.get(name, -1) for name in wanted], dtype=int)


def take_joints(values: np.ndarray, order: np.ndarray, fill: float = np.nan) -> np.ndarray:
    """values[..., order] along the last axis, with `fill` where order is -1 (a joint not there)."""
    values = np.asarray(values, dtype=float)
    out = values[..., np.maximum(order, 0)]
    if np.any(order < 0):
        out = np.array(out, copy=True)
        out[..., order < 0] = fill
    return out
