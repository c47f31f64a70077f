"""Offline picks from dump.py's pickle: `python pick.py DUMP [MEASURE THRESHOLD]` prints found / wrong per set, with
candidates whose trial head measure (c["head"][MEASURE], see trial.diff) reaches THRESHOLD scored 0, then picked by
still_ball._pick and scored by real_bench.score (leonhart, goal5) or by the still-render rule (within one diameter)."""
import math
import pickle
import sys
from pathlib import Path
from types import SimpleNamespace

from foos_vision import real_bench
from foos_vision.detection.still_ball import StillCandidate, _pick

data = pickle.load(open(sys.argv[1], "rb"))
measure = sys.argv[2] if len(sys.argv) > 2 else None
threshold = float(sys.argv[3]) if len(sys.argv) > 3 else math.inf


def pick(radius, cands):
    if radius is None:
        return None
    cs = []
    for c in cands:
        score = 0.0 if measure and c["head"].get(measure, 0.0) >= threshold else c["score"]
        cs.append(StillCandidate(c["u"], c["v"], 0, 0, c["shape"], c["rim"], c["team_balls"], score, c["cue"]))
    cs.sort(key=lambda c: -c.score)
    return _pick(cs, SimpleNamespace(ball_radius_px=radius))


line = f"{measure} >= {threshold}: "
for name in ("leonhart", "goal5"):
    if name not in data:
        continue
    clip = real_bench.read_clip(Path("/work/shared/realdata") / name)
    found = {}
    for k, (radius, cands) in data[name].items():
        b = pick(radius, cands)
        if b is not None:
            found[k] = (b.u, b.v)
    r = real_bench.score(clip, found, len(data[name]), "stills")
    line += f"{name} {r.found}/{r.false} "
if "renders" in data:
    found = wrong = none = 0
    for _, (u, v, diameter), radius, cands in data["renders"]:
        b = pick(radius, cands)
        if b is None:
            none += 1
            continue
        error = math.hypot(b.u - u, b.v - v)
        found += error <= diameter
        wrong += error > 2 * diameter
    line += f"renders {found}/{wrong} (none {none})"
print(line)
