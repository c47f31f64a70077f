"""Per-episode training metrics (metrics.csv) and the paper-style figures (ROS-free).

Columns: episode, timesteps, return, length, win, lose, term_goal, touches, goal_after_touch,
goal_without_touch, then the paper's 50-episode moving averages Return50, EpLen50, WinRate50,
LoseRate50, TermGoal50, then wall_s (seconds since training began) and stage (the reset/opponent the
episode was played on: a curriculum's stage, else the task).
"""
from __future__ import annotations

import csv
import time
from collections import deque
from pathlib import Path
from typing import Iterable

import numpy as np

WINDOW = 50
RAW_COLUMNS = ("episode", "timesteps", "return", "length", "win", "lose", "term_goal", "touches",
               "goal_after_touch", "goal_without_touch")
SMOOTHED = {"Return50": "return", "EpLen50": "length", "WinRate50": "win", "LoseRate50": "lose", "TermGoal50": "term_goal"}
COLUMNS = RAW_COLUMNS + tuple(SMOOTHED)
CLOCK_COLUMNS = ("wall_s", "stage")  # written since the curriculum; older files lack them


class MetricsWriter:
    """Appends one row per finished episode and flushes it, so an interrupted run keeps its rows."""

    def __init__(self, path: str | Path):
        self.path = Path(path)
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file = open(self.path, "w", newline="")
        self._csv = csv.writer(self._file)
        self._csv.writerow(COLUMNS + CLOCK_COLUMNS)
        self._windows = {name: deque(maxlen=WINDOW) for name in SMOOTHED}
        self.episodes = 0
        self._start = time.time()

    def add(self, timesteps: int, stats: dict) -> None:
        self.episodes += 1
        raw = {"episode": self.episodes, "timesteps": timesteps, **{k: stats[k] for k in RAW_COLUMNS[2:]}}
        smoothed = {}
        for name, key in SMOOTHED.items():
            self._windows[name].append(float(stats[key]))
            smoothed[name] = float(np.mean(self._windows[name]))
        row = [raw[c] for c in RAW_COLUMNS] + [smoothed[c] for c in SMOOTHED] + [round(time.time() - self._start, 1), stats.get("task", "")]
        self._csv.writerow([f"{v:.6g}" if isinstance(v, float) else v for v in row])
        self._file.flush()

    def close(self) -> None:
        self._file.close()


def read_metrics(path: str | Path) -> dict[str, np.ndarray]:
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no metrics file at {path}")
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise ValueError(f"{path} holds no episodes")
    missing = [c for c in COLUMNS if c not in rows[0]]
    if missing:
        raise ValueError(f"{path} is not a metrics.csv (missing columns {', '.join(missing)})")
    columns = COLUMNS + (("wall_s",) if "wall_s" in rows[0] else ())
    return {c: np.array([float(r[c]) for r in rows]) for c in columns}


def plot_metrics(metrics_path: str | Path, out_dir: str | Path, title: str = "") -> list[Path]:
    """The paper's Figures 6-12 analogues: smoothed return, length, win, lose, goal-termination rates
    against episodes, and return against episode length. Returns the written PNG paths."""
    import matplotlib  # here: matplotlib takes most of a second to import, and only a finished run plots

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after use("Agg"): no display is needed

    m = read_metrics(metrics_path)
    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    panels = (
        ("return50", "Return50", "smoothed return (50 episodes)"),
        ("eplen50", "EpLen50", "smoothed episode length [steps]"),
        ("winrate50", "WinRate50", "win rate (50 episodes)"),
        ("loserate50", "LoseRate50", "lose rate (50 episodes)"),
        ("termgoal50", "TermGoal50", "goal-termination rate (50 episodes)"),
    )
    for stem, column, label in panels:
        fig, ax = plt.subplots(figsize=(6, 3.5))
        ax.plot(m["episode"], m[column], lw=1.2)
        ax.set_xlabel("episode")
        ax.set_ylabel(label)
        if "rate" in label:
            ax.set_ylim(-0.02, 1.02)
        ax.set_title(title)
        ax.grid(alpha=0.3)
        fig.tight_layout()
        path = out_dir / f"{stem}.png"
        fig.savefig(path, dpi=100)
        plt.close(fig)
        written.append(path)
    # the learning curve against what it cost: steps, and wall-clock where the file has it
    clocks = [("timesteps", "env steps")] + ([("wall_s", "wall-clock [min]")] if "wall_s" in m else [])
    fig, axes = plt.subplots(1, len(clocks), figsize=(5.5 * len(clocks), 3.5), squeeze=False)
    for ax, (column, label) in zip(axes[0], clocks):
        x = m[column] / (60.0 if column == "wall_s" else 1.0)
        ax.plot(x, m["WinRate50"], lw=1.2, label="win rate (50 episodes)")
        ax.plot(x, m["LoseRate50"], lw=1.2, label="own-goal rate (50 episodes)")
        ax.set_xlabel(label)
        ax.set_ylim(-0.02, 1.02)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
    axes[0][0].set_title(title)
    fig.tight_layout()
    path = out_dir / "learning_curve.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    written.append(path)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    sc = ax.scatter(m["length"], m["return"], c=m["episode"], s=6, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="episode")
    ax.set_xlabel("episode length [steps]")
    ax.set_ylabel("return")
    ax.set_title(title)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    path = out_dir / "return_vs_length.png"
    fig.savefig(path, dpi=100)
    plt.close(fig)
    written.append(path)
    return written


def summarize_tail(metrics_path: str | Path, episodes: int = WINDOW) -> dict[str, float]:
    m = read_metrics(metrics_path)
    tail = slice(-episodes, None)
    return {
        "episodes": int(m["episode"][-1]),
        "timesteps": int(m["timesteps"][-1]),
        "Return50": float(np.mean(m["return"][tail])),
        "EpLen50": float(np.mean(m["length"][tail])),
        "WinRate50": float(np.mean(m["win"][tail])),
        "LoseRate50": float(np.mean(m["lose"][tail])),
        "TermGoal50": float(np.mean(m["term_goal"][tail])),
    }


def iter_rows(path: str | Path) -> Iterable[dict]:
    with open(path, newline="") as f:
        yield from csv.DictReader(f)
