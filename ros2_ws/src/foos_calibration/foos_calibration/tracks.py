"""Measured ball detections: validation, tracks, wall contacts and the segments a model should predict.

A track is an uninterrupted stretch of detections (a gap over MAX_GAP or a jump no ball can make
starts a new one: the ball was picked up). A track is cut at wall contacts into flights. A flight
that begins at a bounce starts sliding (the spin no longer matches the velocity): its first segment
is marked `slide`, and the point model fits its slip too, so the slide's data counts. Its
`rolls_from` is when the ball surely rolls again (`settle_time`); what needs a rolling ball (a
prediction's start) waits for that. Bounces themselves are fitted separately.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view as windows

from foos_core.table_geometry import TableGeometry

MAX_GAP = 0.15  # s without a detection that ends a track
MAX_SPEED = 8.0  # m/s; a faster apparent jump is a new launch or an outlier
WALL_ZONE = 0.006  # m: within ball radius + this of a wall, the ball is taken to be in contact
STOP_SPEED = 0.05  # m/s; slower than this the ball is at rest, not rolling
MIN_SEGMENT = 0.25  # s
MAX_SEGMENT = 1.5  # s, fitting pieces (each gets its own initial state)
MIN_DETECTIONS = 200
FRAME_PERIOD = (0.0005, 0.1)  # s: the median interval of a camera's detections (2000 to 10 frames/s)
OUTLIER_WINDOW = 0.5  # s: a cubic in t follows a rolling ball to well under the noise over this long
OUTLIER_SIGMAS = 4.0
OUTLIER_FLOOR = 0.003  # m: a detection off its neighbours' smooth path by more than this (and 4 sigma) is dropped
FIGURE_HOLD = 0.1  # s: a figure contact longer than this held the ball (its spin is not the one it came with)


class DataError(ValueError):
    """Measured data that cannot be calibrated on (one-line reason)."""


def wall_distance(geometry: TableGeometry, xy: np.ndarray) -> np.ndarray:
    """Distance (n,) from the ball centre to the nearest wall it can touch, minus the radius."""
    x, y = np.abs(xy[:, 0]), np.abs(xy[:, 1])
    side = geometry.half_width - geometry.ball_radius - x
    end = geometry.half_length - geometry.ball_radius - y
    # In front of a goal mouth there is no end wall to bounce from.
    end = np.where(x < geometry.goal_half_width - geometry.ball_radius, np.inf, end)
    post = np.hypot(x - geometry.goal_half_width, y - geometry.half_length) - geometry.ball_radius  # goal post edges
    return np.minimum(np.minimum(side, end), post)


def on_field(geometry: TableGeometry, xy: np.ndarray) -> np.ndarray:
    return (np.abs(xy[:, 0]) <= geometry.half_width) & (np.abs(xy[:, 1]) <= geometry.half_length)


@dataclass
class Flight:
    """Detections between two wall contacts (or a track's ends)."""

    track: int
    t: np.ndarray
    xy: np.ndarray
    after_bounce: bool
    before_bounce: bool
    bounce_wall_in: str | None = None  # the wall of the bounce that starts this flight
    v_in: np.ndarray | None = None  # velocity before that bounce (linear fit)
    after_figure: bool = False  # starts where a figure let go of the ball (v_in: the velocity before the touch)


@dataclass
class Segment:
    """A rolling piece of a flight: the fit gives it its own initial state."""

    track: int
    flight: int
    t: np.ndarray
    xy: np.ndarray
    fold: int = 0  # held-out fold: alternating along the recording, so both folds see every place
    slide: bool = False  # starts just after a wall bounce, with the ball sliding
    slip_guess: np.ndarray | None = None  # a first guess of the slip (m/s) at the start, from the bounce
    rolls_from: float = -np.inf  # s; from here on the ball surely rolls


@dataclass
class Bounce:
    """A wall contact with rolling data before it and data after it."""

    track: int
    wall: str  # side_neg_x, side_pos_x, end_home, end_away
    t_contact: float
    before: int  # index of the flight before
    after: int
    t: np.ndarray = field(default_factory=lambda: np.zeros(0))
    xy: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))


def validate(t: np.ndarray, position: np.ndarray, frame_id: str) -> tuple[np.ndarray, np.ndarray]:
    if frame_id not in ("table", ""):
        raise DataError(f"/ball/detection is in frame `{frame_id}`, expected `table`")
    t = np.asarray(t, dtype=float)
    position = np.asarray(position, dtype=float)
    if len(t) < MIN_DETECTIONS:
        raise DataError(f"too little data: {len(t)} ball detections (need at least {MIN_DETECTIONS})")
    if not (np.all(np.isfinite(t)) and np.all(np.isfinite(position))):
        raise DataError("ball detections contain NaN or infinite values")
    if np.any(np.diff(t) < 0):
        raise DataError("detection timestamps go backwards")
    keep = np.concatenate([[True], np.diff(t) > 1e-6])  # a repeated stamp is a duplicate message
    if keep.sum() < len(t) / 2:
        raise DataError(f"a broken time base: {len(t) - int(keep.sum())} of {len(t)} detections repeat the stamp before them "
                        "(stamps of arrival batches, or a clock that stood still?)")
    period = float(np.median(np.diff(t[keep])))
    if not FRAME_PERIOD[0] <= period <= FRAME_PERIOD[1]:
        raise DataError(f"a broken time base: the detections' median interval is {period:.3g} s, no camera's frame period "
                        f"({FRAME_PERIOD[0] * 1000:g}-{FRAME_PERIOD[1] * 1000:g} ms); stamps in the wrong unit?")
    return t[keep], position[keep, :2]


def split_tracks(t: np.ndarray, xy: np.ndarray) -> list[tuple[np.ndarray, np.ndarray]]:
    dt = np.diff(t)
    jump = np.linalg.norm(np.diff(xy, axis=0), axis=1)
    cut = np.flatnonzero((dt > MAX_GAP) | (jump > MAX_SPEED * np.maximum(dt, 1e-3)))
    bounds = np.concatenate([[0], cut + 1, [len(t)]])
    return [(t[a:b], xy[a:b]) for a, b in zip(bounds[:-1], bounds[1:]) if b - a >= 10]


def _linear_velocity(t: np.ndarray, xy: np.ndarray) -> np.ndarray:
    if len(t) < 3:
        return np.zeros(2)
    A = np.stack([np.ones_like(t), t - t.mean()], axis=1)
    coef, *_ = np.linalg.lstsq(A, xy, rcond=None)
    return coef[1]


def _window_velocity(t: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Least-squares velocity over each window of frames: t (n, w), xy (n, w, 2) -> (n, 2)."""
    tc = t - t.mean(axis=1, keepdims=True)
    xc = xy - xy.mean(axis=1, keepdims=True)
    return np.einsum("nw,nwk->nk", tc, xc) / np.maximum(np.sum(tc**2, axis=1), 1e-12)[:, None]


def velocity_change(t: np.ndarray, xy: np.ndarray, window: int = 6) -> tuple[np.ndarray, np.ndarray, float]:
    """Per frame (n,): how much the velocity of the `window` frames after it differs from that of the
    `window` frames before it, and the speed after it (zeros for a track shorter than 2 windows); and the
    change the detection noise alone gives (m/s, the standard deviation of one component)."""
    n = len(t)
    change, speed = np.zeros(n), np.zeros(n)
    if n < 2 * window:
        return change, speed, 0.0
    tw, pw = windows(t, window), windows(xy, window, axis=0).transpose(0, 2, 1)
    v = _window_velocity(tw, pw)  # velocity of frames i .. i+window-1
    # frame i: before = window ending at i, after = window starting at i
    change[window - 1: n - window + 1] = np.linalg.norm(v[window - 1:] - v[: n - 2 * window + 2], axis=1)
    speed[: len(v)] = np.linalg.norm(v, axis=1)
    speed[len(v):] = speed[len(v) - 1]
    second = xy[2:] - 2 * xy[1:-1] + xy[:-2]  # dominated by the noise: sqrt(6) sigma
    sigma = 1.4826 * float(np.median(np.abs(second))) / np.sqrt(6)
    spread = float(np.median(np.sum((tw - tw.mean(axis=1, keepdims=True)) ** 2, axis=1)))
    return change, speed, float(np.sqrt(2.0) * sigma / np.sqrt(max(spread, 1e-12)))


def contact_frames(geometry: TableGeometry, t: np.ndarray, xy: np.ndarray, window: int = 6) -> np.ndarray:
    """Frames at or around a wall contact.

    At 3 m/s the ball moves 25 mm between frames, so a bounce is often never seen within a few mm of
    the wall: a frame also counts when it is near a wall and the velocity after it differs from the
    velocity before it by more than the noise allows.
    """
    distance = wall_distance(geometry, xy)
    near = distance < WALL_ZONE
    n = len(t)
    if n >= 2 * window:
        change, speed, _noise = velocity_change(t, xy, window)
        reach = 0.01 + 1.5 * speed * np.median(np.diff(t))
        near |= (change > 0.25) & (distance < reach)
        # The first and last frames of a track have no window on one side to compare with: a ball
        # launched toward a wall bounces before the test can see it. Near a wall there, assume contact.
        unseen = np.zeros(n, dtype=bool)
        unseen[: window - 1] = True
        unseen[n - window + 1:] = True
        near |= unseen & (distance < reach)
    return near


def _which_wall(geometry: TableGeometry, xy: np.ndarray) -> str:
    x, y = xy
    side = geometry.half_width - abs(x)
    end = geometry.half_length - abs(y)
    if side < end:
        return "side_pos_x" if x > 0 else "side_neg_x"
    return "end_away" if y > 0 else "end_home"


def flights_of_track(geometry: TableGeometry, track: int, t: np.ndarray,
                     xy: np.ndarray) -> tuple[list[Flight], list[tuple[int, int, float, str]]]:
    """Flights, and contacts as (flight before, flight after, time, wall) within one track."""
    inside = on_field(geometry, xy)
    if not np.all(inside):  # the ball left the field (a goal): the track ends there
        stop = int(np.argmin(inside))
        t, xy = t[:stop], xy[:stop]
    near = contact_frames(geometry, t, xy)
    flights: list[Flight] = []
    contacts: list[tuple[int, int, float, str]] = []
    i, n = 0, len(t)
    pending = None  # (contact time, wall, velocity in) of the contact before the next flight
    while i < n:
        if near[i]:
            j = i
            while j < n and near[j]:
                j += 1
            k = int(i + np.argmin(wall_distance(geometry, xy[i:j])))
            wall = _which_wall(geometry, xy[k])
            before = flights[-1] if flights else None
            v_in = _linear_velocity(before.t[-12:], before.xy[-12:]) if before is not None and len(before.t) >= 6 else None
            pending = (float(t[k]), wall, v_in, len(flights) - 1 if before is not None else None)
            if before is not None:
                before.before_bounce = True
            i = j
            continue
        j = i
        while j < n and not near[j]:
            j += 1
        flight = Flight(track, t[i:j], xy[i:j], after_bounce=pending is not None, before_bounce=False)
        if pending is not None:
            flight.bounce_wall_in, flight.v_in = pending[1], pending[2]
            if pending[3] is not None:
                contacts.append((pending[3], len(flights), pending[0], pending[1]))
        flights.append(flight)
        pending = None
        i = j
    return flights, contacts


def normal_speed(wall: str, v: np.ndarray) -> float:
    """Speed toward the wall (positive when approaching)."""
    if wall.startswith("side"):
        return float(v[0] if wall.endswith("pos_x") else -v[0])
    return float(v[1] if wall == "end_away" else -v[1])


def settle_time(normal_in: float) -> float:
    """Time after a bounce until the ball rolls again: sliding friction has to match spin to velocity.

    The slip after a bounce is about (1 + e) v_n plus what the wall's friction does to the spin;
    sliding friction (0.3 g) removes it at 7/2 mu g. The margin covers e up to 0.9 and the wall.
    """
    return 0.05 + 0.28 * abs(normal_in)


def drop_outliers(t: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Mask (n,) of detections that lie on their neighbours' smooth path.

    A camera's detections of a ball passing under a rod or figure are biased for a frame or two (the
    part of the ball in view is off centre: 4-11 mm measured through the renderer and tracker, against
    ~1 mm elsewhere). Left in, those fixed-place errors look like a local surface effect (a bump near a
    rod). Each window of OUTLIER_WINDOW s is fitted with a cubic in t, and detections off it by more
    than max(4 robust sigmas, 3 mm) are left out. Gaussian noise loses almost nothing.
    """
    n = len(t)
    residual = np.zeros(n)
    pieces = max(1, int(np.ceil((t[-1] - t[0]) / OUTLIER_WINDOW)))
    edges = np.linspace(t[0], t[-1] + 1e-9, pieces + 1)
    for a, b in zip(edges[:-1], edges[1:]):
        m = (t >= a) & (t < b)
        if m.sum() < 8:
            continue
        tc = t[m] - t[m].mean()
        A = np.stack([np.ones_like(tc), tc, tc**2, tc**3], axis=1)
        coef, *_ = np.linalg.lstsq(A, xy[m], rcond=None)
        residual[m] = np.linalg.norm(xy[m] - A @ coef, axis=1)
    sigma = 1.4826 * np.median(residual) / 1.1774  # median of a 2-D Gaussian's radius is 1.1774 sigma
    return residual <= max(OUTLIER_SIGMAS * sigma, OUTLIER_FLOOR)


SLIDE_MAX_NORMAL_SPEED = 1.5  # m/s into the wall; faster, the ball hops off the field (see rolling_segments)
WALL_INTO = {"side_pos_x": (1.0, 0.0), "side_neg_x": (-1.0, 0.0), "end_away": (0.0, 1.0), "end_home": (0.0, -1.0)}
NOMINAL_RESTITUTION = 0.75  # only for the first guess of a slip; the fit finds the slip itself


def incoming_normal_speed(wall: str, v_in: np.ndarray | None, v_out: np.ndarray) -> float:
    """Best estimate of the speed into the wall: measured before the bounce, else from the speed out."""
    normal = normal_speed(wall, v_in) if v_in is not None else abs(normal_speed(wall, v_out)) / NOMINAL_RESTITUTION
    return max(normal, 0.0)


def slip_after_bounce(wall: str, v_in: np.ndarray | None, v_out: np.ndarray) -> np.ndarray:
    """First guess of the slip just after a bounce from a rolling ball.

    The wall reverses the normal velocity, e v_n, but not the spin, so the contact point slips at
    -(1 + e) v_n along the wall's normal (away from the wall).
    """
    return -(1.0 + NOMINAL_RESTITUTION) * incoming_normal_speed(wall, v_in, v_out) * np.array(WALL_INTO[wall])


def slip_after_figure(flight: Flight) -> tuple[np.ndarray | None, float]:
    """First guess of the slip after a figure let go of the ball, or None after a kick too hard to slide on
    (see the fast wall bounce below); and when the ball surely rolls again.

    The figure changed the velocity but not (much) the spin, which still matches the velocity before: the
    contact point slips at v_out - v_in. Without a velocity before (the figure held the ball, or the flight
    before was too short), assume no spin: slip = v_out. Sliding friction removes a slip u in |u| / (7/2 mu g),
    0.1 s per m/s; the margin covers an unknown spin of up to 1 m/s of rolling speed.
    """
    v_out = _linear_velocity(flight.t[:8], flight.xy[:8])
    slip = v_out - flight.v_in if flight.v_in is not None else v_out
    bound = float(np.linalg.norm(slip)) + (0.0 if flight.v_in is not None else 1.0)
    rolls_from = flight.t[0] + 0.05 + 0.16 * bound
    if np.linalg.norm(slip) > (1.0 + NOMINAL_RESTITUTION) * SLIDE_MAX_NORMAL_SPEED:
        return None, rolls_from
    return slip, rolls_from


def rolling_segments(flight: Flight, index: int) -> list[Segment]:
    t, xy = flight.t, flight.xy
    rolls_from = -np.inf
    slip = None
    if flight.after_figure and len(t) >= 8:
        slip, rolls_from = slip_after_figure(flight)
        if slip is None:  # a hard kick: the ball may hop; the fit starts where it surely rolls
            keep = t >= rolls_from
            t, xy = t[keep], xy[keep]
    elif flight.after_bounce and len(t) >= 8:
        # Incoming normal speed from before the bounce; where that flight is too short to tell,
        # from the outgoing speed and the lowest restitution a table could have.
        normal = normal_speed(flight.bounce_wall_in, flight.v_in) if flight.v_in is not None else 0.0
        v_out = _linear_velocity(t[:8], xy[:8])
        normal = max(normal, abs(normal_speed(flight.bounce_wall_in, v_out)) / 0.4)
        rolls_from = t[0] + settle_time(normal)
        if incoming_normal_speed(flight.bounce_wall_in, flight.v_in, v_out) <= SLIDE_MAX_NORMAL_SPEED:
            slip = slip_after_bounce(flight.bounce_wall_in, flight.v_in, v_out)
        else:
            # A fast bounce makes the ball hop (in MuJoCo 2.4 mm at 1.5 m/s, 10 mm and 0.3 s in the air at
            # 2.5 m/s): no friction while it flies, then a jolt when it lands. The slide model misfits that
            # by 0.5-1.2 mm rms above 2 m/s (0.2 mm at 1.5), so such a slide is left out; the fit starts
            # where the ball surely rolls again.
            keep = t >= rolls_from
            t, xy = t[keep], xy[keep]
    if len(t) < 10:
        return []
    # Stop where the ball comes to rest (speed from 0.2 s chords).
    step = max(1, int(round(0.2 / max(np.median(np.diff(t)), 1e-3))))
    if len(t) > step:
        speed = np.linalg.norm(xy[step:] - xy[:-step], axis=1) / (t[step:] - t[:-step])
        slow = np.flatnonzero(speed < STOP_SPEED)
        if slow.size:
            t, xy = t[: slow[0] + step // 2], xy[: slow[0] + step // 2]
    if flight.before_bounce:  # two frames of margin before the contact zone
        t, xy = t[:-2], xy[:-2]
    segments = []
    if len(t) == 0 or t[-1] - t[0] < MIN_SEGMENT:
        return segments
    pieces = max(1, int(np.ceil((t[-1] - t[0]) / MAX_SEGMENT)))
    edges = np.linspace(t[0], t[-1] + 1e-9, pieces + 1)
    for a, b in zip(edges[:-1], edges[1:]):
        m = (t >= a) & (t < b)
        if m.sum() >= 20 and t[m][-1] - t[m][0] >= MIN_SEGMENT:
            # A cubic cannot follow the end of a slide (the pull stops at once), so only the rolling
            # part is checked for outliers.
            keep = np.ones(m.sum(), dtype=bool)
            rolling = t[m] >= rolls_from
            if rolling.sum() >= 8:
                keep[rolling] = drop_outliers(t[m][rolling], xy[m][rolling])
            first = a == edges[0] and slip is not None
            segments.append(Segment(flight.track, index, t[m][keep], xy[m][keep], slide=first,
                                    slip_guess=slip if first else None, rolls_from=rolls_from))
    return segments


@dataclass
class Measured:
    """Everything calibration needs from the detections."""

    t: np.ndarray
    xy: np.ndarray
    tracks: list[tuple[np.ndarray, np.ndarray]]
    flights: list[Flight]
    segments: list[Segment]
    bounces: list[Bounce]
    noise: float  # m, detection noise estimated from second differences


def cut_at_figures(t: np.ndarray, xy: np.ndarray, figures) -> list[tuple[np.ndarray, np.ndarray, bool, np.ndarray | None, bool]]:
    """A track's stretches between figure contacts: (t, xy, starts after a figure contact, the velocity before
    that contact where the touch was brief, ends at a figure contact). The contact frames themselves, and
    every frame while a figure holds the ball, are left out."""
    touched = figures.contact_frames(t, xy)
    pieces = []
    bounds = np.flatnonzero(np.diff(np.concatenate([[1], touched.astype(int), [1]])))  # free runs: [a, b)
    for a, b in zip(bounds[0::2], bounds[1::2]):
        v_in = None
        if a > 0:
            hold_start = a - 1
            while hold_start > 0 and touched[hold_start - 1]:
                hold_start -= 1
            before = slice(max(0, hold_start - 12), hold_start)
            if hold_start >= 6 and t[a - 1] - t[hold_start] <= FIGURE_HOLD:
                v_in = _linear_velocity(t[before], xy[before])
        if b - a >= 10:
            pieces.append((t[a:b], xy[a:b], a > 0, v_in, b < len(t)))
    return pieces


def analyse(t: np.ndarray, xy: np.ndarray, geometry: TableGeometry, figures=None) -> Measured:
    """Tracks, flights, rolling segments and wall bounces. `figures` (figure_contacts.for_game) also cuts the
    tracks at figure contacts: each stretch between them is a track of its own, so no flight, bounce window
    or prediction runs through a figure. None: only walls (free rolls with the rods lifted)."""
    tracks = split_tracks(t, xy)
    pieces = [(tt, pp, False, None, False) for tt, pp in tracks]
    if figures is not None:
        pieces = [piece for tt, pp in tracks for piece in cut_at_figures(tt, pp, figures)]
        tracks = [(tt, pp) for tt, pp, *_ in pieces]
    flights: list[Flight] = []
    segments: list[Segment] = []
    bounces: list[Bounce] = []
    for k, (tt, pp, after_figure, v_in, before_figure) in enumerate(pieces):
        fl, contacts = flights_of_track(geometry, k, tt, pp)
        if fl and after_figure and not fl[0].after_bounce and fl[0].t[0] == tt[0]:
            fl[0].after_figure, fl[0].v_in = True, v_in
        if fl and before_figure:
            fl[-1].before_bounce = True
        base = len(flights)
        flights += fl
        for f_index, flight in enumerate(fl):
            segments += rolling_segments(flight, base + f_index)
        for before, after, t_contact, wall in contacts:
            bounces.append(Bounce(k, wall, t_contact, base + before, base + after))
    for i, s in enumerate(segments):
        s.fold = i % 2
    # Noise: second differences of 3 consecutive frames are dominated by it (sqrt(6) sigma).
    d2 = []
    for tt, pp in tracks:
        ok = (np.abs(np.diff(tt)[1:] - np.diff(tt)[:-1]) < 1e-4)
        if len(pp) > 3:
            second = pp[2:] - 2 * pp[1:-1] + pp[:-2]
            d2.append(second[ok])
    d2 = np.concatenate(d2) if d2 else np.zeros((0, 2))
    noise = float(1.4826 * np.median(np.abs(d2)) / np.sqrt(6)) if len(d2) > 20 else 0.0015
    return Measured(t, xy, tracks, flights, segments, bounces, max(noise, 2e-4))
