"""`python verdicts.py DUMP MEASURE THRESHOLD`: the leonhart frames not found (missed / wrong / near) under pick.py's rule."""
import pickle
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np

from foos_vision import real_bench
from foos_vision.detection.still_ball import StillCandidate, _pick

data = pickle.load(open(sys.argv[1], "rb"))
measure, thr = sys.argv[2], float(sys.argv[3])
clip = real_bench.read_clip(Path("/work/shared/realdata/leonhart"))
dia = float(np.median([w for b in clip.labels.values() for _, _, w in b]))
out = []
for k in sorted(clip.labels):
    radius, cands = data["leonhart"][k]
    cs = [StillCandidate(c["u"], c["v"], 0, 0, c["shape"], c["rim"], c["team_balls"],
                         0.0 if c["head"].get(measure, 0) >= thr else c["score"], c["cue"]) for c in cands]
    cs.sort(key=lambda c: -c.score)
    b = _pick(cs, SimpleNamespace(ball_radius_px=radius)) if radius else None
    v, e, _ = real_bench.judge_frame(clip.labels[k], None if b is None else (b.u, b.v), dia)
    if v != "found":
        out.append(f"{clip.frames[k].stem}:{v}")
print(" ".join(out))
