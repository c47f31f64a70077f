"""Training win / own-goal rates over windows of 200 episodes, from each run's metrics.csv.

usage: python windows.py RUN/metrics.csv ...   (prints: thousands of steps at each window's end: win/lose)"""
import csv
import sys

import numpy as np

WINDOW = 200

for path in sys.argv[1:]:
    with open(path) as f:
        rows = list(csv.DictReader(f))
    win = np.array([float(r["win"]) for r in rows])
    lose = np.array([float(r["lose"]) for r in rows])
    steps = [int(r["timesteps"]) for r in rows]
    windows = []
    for start in range(0, len(rows), WINDOW):
        end = min(start + WINDOW, len(rows))
        windows.append(f"{steps[end - 1] // 1000}k:{win[start:end].mean():.2f}/{lose[start:end].mean():.2f}")
    print(path, len(rows), " ".join(windows))
