"""Sudden changes of the ball's velocity away from the walls, located in time and place from the detections alone.

A figure's touch turns the ball's straight path between two camera frames. The path before and after is a
line each (least squares over KINK_FRAMES frames, leaving out the frames nearest the turn, which the touch may
have moved), and the touch is where the two lines meet: the moment that brings them closest, and the point
half way between them then. A clean bounce's lines meet within a few mm (the noise); a ball pushed or held
by a figure for several frames does not, and is left out. A turn within WALL_CLEAR of a wall is the wall's.

What the kinks are for: `camera_clock` poses the figures at each kink's time to find the camera's latency
against the encoders, `figure_bounces` takes the velocities either side to measure the figures' restitution.
Nothing here knows about the figures.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view as windows

from foos_core.table_geometry import TableGeometry

from .tracks import split_tracks, velocity_change, wall_distance

KINK_FRAMES = 4  # frames of each line (~33 ms at 120 fps: long enough to average the noise, short for a roll)
SKIP = 1  # frames either side of the velocity-change peak left out of both lines (the touch is among them)
MIN_CHANGE = 0.4  # m/s between the two lines: smaller turns are not located well enough in time
WALL_CLEAR = 0.02  # m: a kink whose ball is this close to a wall (surface to surface) may be the wall's
MAX_MISS = 0.006  # m the two lines may pass apart at their closest (a clean instantaneous bounce)
MAX_LINE_RMS = 3.0  # times the detection noise: a line's residual above this is no straight path
MAX_LINE_GAP = 1.6  # times the median frame interval: no dropout inside the frames used


@dataclass
class Kink:
    """One located turn of the ball's path (times on the detections' clock)."""

    t: float  # s, when the two lines meet
    xy: np.ndarray  # (2,) the ball centre then
    v_before: np.ndarray  # (2,) m/s
    v_after: np.ndarray
    miss: float  # m, how far apart the two lines pass
    index: int  # detection index of the velocity-change peak


def detection_noise(t: np.ndarray, xy: np.ndarray) -> float:
    """m: one axis' detection noise from second differences of consecutive frames (robust to the kinks)."""
    d2 = []
    for tt, pp in split_tracks(t, xy):
        if len(tt) >= 3:
            d2.append(pp[2:] - 2 * pp[1:-1] + pp[:-2])
    if not d2:
        return 0.0
    values = np.concatenate(d2).ravel()
    return float(1.4826 * np.median(np.abs(values - np.median(values))) / np.sqrt(6.0))


def _line(t: np.ndarray, xy: np.ndarray, t0: float) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares line xy = a + v (t - t0): a, v and the residual RMS (per axis)."""
    A = np.stack([np.ones_like(t), t - t0], axis=1)
    coef, *_ = np.linalg.lstsq(A, xy, rcond=None)
    residual = xy - A @ coef
    return coef[0], coef[1], float(np.sqrt(np.mean(residual**2) * len(t) / max(len(t) - 2, 1)))


def find_kinks(t: np.ndarray, xy: np.ndarray, geometry: TableGeometry, noise: float | None = None) -> list[Kink]:
    """Every clean turn of the ball's path away from the walls, in time order."""
    noise = detection_noise(t, xy) if noise is None else noise
    kinks: list[Kink] = []
    half = KINK_FRAMES + SKIP
    for tt, pp in split_tracks(t, xy):
        if len(tt) < 2 * half + 2:
            continue
        change, _speed, _ = velocity_change(tt, pp, KINK_FRAMES + 1)
        padded = np.concatenate([np.zeros(half), change, np.zeros(half)])
        peaks = np.flatnonzero((change > MIN_CHANGE) & (change >= windows(padded, 2 * half + 1).max(axis=1)))
        frame_dt = float(np.median(np.diff(tt)))
        wall = wall_distance(geometry, pp)
        offset = int(np.searchsorted(t, tt[0]))
        for p in peaks:
            before = np.arange(p - SKIP - KINK_FRAMES, p - SKIP)
            after = np.arange(p + SKIP, p + SKIP + KINK_FRAMES)
            if before[0] < 0 or after[-1] >= len(tt):
                continue
            if np.min(wall[before[0]:after[-1] + 1]) < WALL_CLEAR:
                continue
            if np.max(np.diff(tt[before])) > MAX_LINE_GAP * frame_dt or np.max(np.diff(tt[after])) > MAX_LINE_GAP * frame_dt:
                continue
            t0 = float(tt[p])
            a_b, v_b, rms_b = _line(tt[before], pp[before], t0)
            a_a, v_a, rms_a = _line(tt[after], pp[after], t0)
            dv = v_a - v_b
            if np.linalg.norm(dv) < MIN_CHANGE or max(rms_b, rms_a) > MAX_LINE_RMS * max(noise, 1e-4):
                continue
            tc = float(-np.dot(a_a - a_b, dv) / np.dot(dv, dv))  # closest approach of the two lines
            if not (tt[before[-1]] - t0 - 0.5 * frame_dt <= tc <= tt[after[0]] - t0 + 0.5 * frame_dt):
                continue  # the lines meet outside the frames that saw the turn: not one touch
            on_b, on_a = a_b + v_b * tc, a_a + v_a * tc
            miss = float(np.linalg.norm(on_a - on_b))
            if miss > MAX_MISS + 2 * noise:
                continue
            kinks.append(Kink(t0 + tc, 0.5 * (on_a + on_b), v_b, v_a, miss, offset + int(p)))
    kinks.sort(key=lambda k: k.t)
    return kinks
