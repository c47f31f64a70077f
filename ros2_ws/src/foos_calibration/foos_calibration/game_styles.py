"""Games that play and are measured like others': players' styles and recording conditions drawn from a seed.

`generate_measured --game --style random` draws, from its seed, one style per team and the recording's
conditions; `--style NAME` gives both teams that style and draws the conditions. The styles change what
the game's own players (games.Player) send:

  default         the generator's own player (track the ball, kick near the line, random bursts)
  bang_bang       every command at a limit, or zero: full speed either way, nothing between
  into_stops      slides driven into their travel stops and held there for 0.3-1.2 s
  spinning        rods spun at 50-100 % of the rotation limit for 1-4 s
  held_still      rods held still (figures down, slide where it was) for 1.5-5 s while the ball strikes them
  fast_commands   a noisy controller sending at 500 Hz, faster than the encoders
  passive         half the gain and few bursts
  aggressive      1.5 times the gain and bursts most of the time

The conditions: encoders at 100-1000 Hz (at most 400 Hz under fast_commands, which sends at 500 Hz) with
0-5 % of samples dropped and a few bursts of 10-40 ms lost; a camera at 60-240 fps with occlusion bursts
(0-0.4 a second, 50-500 ms each) and, in most games, the ball hidden while under a figure; commands sent
every 10 or 20 ms (2 ms under fast_commands), arriving 0-4 ms later (plus up to 1 ms of jitter), and stamped
when sent or on arrival. A command stamped when sent shows its transport delay as a dead time of the drives
(under the 8 ms the identification treats as material): a benchmark's true latency adds it
(`GameStyle.stamp_delay`). The drawn style goes into the bag directory as STYLE_FILE and is printed.
"""
from __future__ import annotations

import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from foos_core.names import COMMAND_SIZE, JOINT_NAMES, RODS, TEAMS

from .games import GameRecording, Player

PLAYER_STYLES = ("default", "bang_bang", "into_stops", "spinning", "held_still", "fast_commands", "passive", "aggressive")
STYLE_FILE = "generator_style.json"
FAST_PERIOD = 0.002  # s: fast_commands sends every physics step (500 Hz)
FIGURE_HIDES = (0.014, 0.012)  # m: half the x and y extent of a figure's body seen from above


class StyleError(ValueError):
    """An unknown style name."""


@dataclass
class GameStyle:
    players: tuple[str, str]  # home, away
    encoder_rate: float  # Hz
    fps: float
    control_period: float  # s between commands
    transport_delay: float  # s, sent -> arrival
    transport_jitter: float  # s, up to this much more per command
    stamps: str  # "sent" or "arrival"
    encoder_drop: float  # share of encoder samples lost one by one
    encoder_bursts: float  # bursts of lost encoder samples per s
    occlusion_bursts: float  # camera occlusion bursts per s
    hide_under_figures: bool
    seed: int = 0
    extra: dict = field(default_factory=dict)

    @property
    def stamp_delay(self) -> float:
        """s: the dead time the stamps add to the drives (a command stamped when sent acts on arrival)."""
        return self.transport_delay + self.transport_jitter / 2 if self.stamps == "sent" else 0.0

    def as_dict(self) -> dict:
        return {k: (list(v) if isinstance(v, tuple) else v) for k, v in asdict(self).items()}

    def describe(self) -> str:
        return (f"style: home {self.players[0]}, away {self.players[1]}; encoders {self.encoder_rate:.0f} Hz "
                f"({self.encoder_drop * 100:.1f} % dropped, {self.encoder_bursts:.2f} bursts/s), camera {self.fps:.0f} fps "
                f"({self.occlusion_bursts:.2f} occlusion bursts/s{', ball hidden under figures' if self.hide_under_figures else ''}), "
                f"commands every {self.control_period * 1000:.0f} ms, {self.transport_delay * 1000:.1f} ms "
                f"(+{self.transport_jitter * 1000:.1f}) to arrive, stamped when {self.stamps}")

    # --- the hooks games.play calls --------------------------------------------------------------------
    def player(self, team: str, base: Player, rng: np.random.Generator) -> "StyledPlayer":
        return StyledPlayer(self.players[0 if team == "home" else 1], base, self.control_period, rng)

    def transport(self, rng: np.random.Generator) -> float:
        return self.transport_delay + float(rng.uniform(0.0, self.transport_jitter))

    def measure(self, recording: GameRecording, params: dict, rng: np.random.Generator) -> GameRecording:
        """The recording as this camera and these encoders saw it: occlusions, the ball under figures, lost samples."""
        keep = np.ones(len(recording.ball_t), dtype=bool)
        t = recording.ball_t
        for start in _bursts(rng, t[0], t[-1], self.occlusion_bursts):
            keep &= ~((t >= start) & (t < start + rng.uniform(0.05, 0.5)))
        if self.hide_under_figures:
            keep &= ~under_a_figure(recording, params)
        joints = rng.random(len(recording.joint_t)) >= self.encoder_drop
        for start in _bursts(rng, recording.joint_t[0], recording.joint_t[-1], self.encoder_bursts):
            joints &= ~((recording.joint_t >= start) & (recording.joint_t < start + rng.uniform(0.01, 0.04)))
        joints[[0, -1]] = True
        recording.ball_t, recording.ball_position = recording.ball_t[keep], recording.ball_position[keep]
        recording.joint_t, recording.joint_position = recording.joint_t[joints], recording.joint_position[joints]
        recording.joint_velocity = recording.joint_velocity[joints]
        return recording


def _bursts(rng: np.random.Generator, start: float, end: float, rate: float) -> np.ndarray:
    return np.sort(rng.uniform(start, end, size=rng.poisson(rate * (end - start))))


def under_a_figure(recording: GameRecording, params: dict) -> np.ndarray:
    """Which detections have the ball under a figure's body (the figures posed from the recorded slides)."""
    layout = params["rods"]["layout"]
    hidden = np.zeros(len(recording.ball_t), dtype=bool)
    xy = recording.ball_position[:, :2]
    for team in TEAMS:
        for rod in RODS:
            r = layout[f"{team}_{rod}"]
            slide = np.interp(recording.ball_t, recording.joint_t, recording.joint_position[:, JOINT_NAMES.index(f"{team}_{rod}_slide")])
            n, spacing = int(r["figures"]), float(r["spacing"])
            near_line = np.abs(xy[:, 1] - float(r["y"])) < FIGURE_HIDES[1]
            for offset in (np.arange(n) - (n - 1) / 2) * spacing:
                hidden |= near_line & (np.abs(xy[:, 0] - slide - offset) < FIGURE_HIDES[0])
    return hidden


class StyledPlayer:
    """A team's player (games.Player) as one of PLAYER_STYLES plays it."""

    def __init__(self, style: str, base: Player, period: float, rng: np.random.Generator):
        self.style, self.base, self.rng, self.period = style, base, rng, period
        base.period = period
        base.excitation = {"passive": 0.05, "aggressive": 0.9}.get(style, base.excitation)
        self.until = [-1.0] * COMMAND_SIZE  # a style's own action per drive, until this time
        self.value = [0.0] * COMMAND_SIZE

    def _starts(self, rate: float) -> bool:
        return self.rng.random() < rate * self.period

    def command(self, time: float, ball: np.ndarray, joints: np.ndarray) -> np.ndarray:
        out = self.base.command(time, ball, joints)
        limits, style = self.base.limits, self.style
        if style == "bang_bang":
            out = np.where(np.abs(out) > 0.1 * limits, np.sign(out) * limits, 0.0)
        elif style == "passive":
            out = 0.5 * out
        elif style == "aggressive":
            out = 1.5 * out
        elif style == "fast_commands":
            out = out + self.rng.normal(0.0, 0.1, size=out.shape) * limits
        elif style in ("into_stops", "spinning", "held_still"):
            for r, rod in enumerate(self.base.rods):
                self._rod(style, r, rod, time, joints, out, limits)
        return np.clip(out, -limits, limits)

    def _rod(self, style, r, rod, time, joints, out, limits) -> None:
        slide, angle = 2 * r, 2 * r + 1
        if time >= self.until[slide] and self._starts({"into_stops": 0.3, "spinning": 0.15, "held_still": 0.2}[style]):
            self.until[slide] = time + self.rng.uniform(*{"into_stops": (0.3, 1.2), "spinning": (1.0, 4.0),
                                                          "held_still": (1.5, 5.0)}[style])
            if style == "into_stops":
                toward = math.copysign(1.0, joints[slide]) if joints[slide] else float(self.rng.choice((-1.0, 1.0)))
                self.value[slide] = toward * self.rng.uniform(0.5, 1.0) * limits[slide]
            elif style == "spinning":
                self.value[slide] = float(self.rng.choice((-1.0, 1.0))) * self.rng.uniform(0.5, 1.0) * limits[angle]
            else:
                self.value[slide] = float(joints[slide])  # held where it was
        if time >= self.until[slide]:
            return
        if style == "into_stops":
            out[slide] = self.value[slide]
        elif style == "spinning":
            out[angle] = self.value[slide]
        else:
            out[slide] = 25.0 * (self.value[slide] - joints[slide])
            out[angle] = 30.0 * (2 * math.pi * round(joints[angle] / (2 * math.pi)) - joints[angle])


def draw(seed: int, style: str = "random") -> GameStyle:
    """A game's style from its seed: both teams' players ("random": each team's drawn) and the recording's conditions."""
    if style != "random" and style not in PLAYER_STYLES:
        raise StyleError(f"unknown style `{style}` (known: random, {', '.join(PLAYER_STYLES)})")
    rng = np.random.default_rng([seed, 27])
    players = tuple(str(rng.choice(PLAYER_STYLES)) for _ in range(2)) if style == "random" else (style, style)
    fast = "fast_commands" in players
    return GameStyle(
        players=players,
        encoder_rate=float(round(rng.uniform(100.0, 400.0 if fast else 1000.0))),
        fps=float(round(rng.uniform(60.0, 240.0))),
        control_period=FAST_PERIOD if fast else float(rng.choice((0.01, 0.02))),
        transport_delay=round(float(rng.uniform(0.0, 0.004)), 4),
        transport_jitter=round(float(rng.uniform(0.0, 0.001)), 4),
        stamps=str(rng.choice(("sent", "arrival"))),
        encoder_drop=round(float(rng.uniform(0.0, 0.05)), 3),
        encoder_bursts=round(float(rng.uniform(0.0, 0.2)), 3),
        occlusion_bursts=round(float(rng.uniform(0.0, 0.4)), 3),
        hide_under_figures=bool(rng.random() < 0.7),
        seed=seed,
    )


def write_style(style: GameStyle, bag: str | Path) -> Path:
    """The drawn style beside the bag's files (a reader of the bag ignores it)."""
    path = Path(bag) / STYLE_FILE
    path.write_text(json.dumps(style.as_dict(), indent=2))
    return path


def read_style(bag: str | Path) -> dict | None:
    path = Path(bag) / STYLE_FILE
    return json.loads(path.read_text()) if path.exists() else None
