"""`python dump.py OUT.pkl leonhart,goal5,renders [NAME=VALUE ...]`: the still finder, with still_ball's constants set
from NAME=VALUE, on leonhart's stills, goal5's frames as stills and the 90 still renders (still_renders' set); pickles
each frame's candidates (and the renders' true centres) for pick.py. Needs trial.diff applied (StillCandidate.head)."""
import pickle
import sys
import time
from pathlib import Path

from foos_vision import real_bench
from foos_vision.detection import still_ball

out = sys.argv[1]
sets = sys.argv[2].split(",")
for arg in sys.argv[3:]:
    k, v = arg.split("=")
    old = getattr(still_ball, k)
    setattr(still_ball, k, (v == "1") if isinstance(old, bool) else type(old)(v))
finder = still_ball.StillBallFinder()
def light(c):
    return dict(u=c.u, v=c.v, cue=c.cue, score=c.score, shape=c.shape, rim=c.rim, team_balls=c.team_balls,
                head=getattr(c, "head", {}))
data = {}
root = Path("/work/shared/realdata")
for name in ("leonhart", "goal5"):
    if name not in sets:
        continue
    clip = real_bench.read_clip(root / name)
    frames = {}
    t = time.process_time()
    for k, _, image in real_bench._frames_of(clip, real_bench.DEFAULT_FPS):
        field, cands = finder.find(image)
        frames[k] = (None if field is None else field.ball_radius_px, [light(c) for c in cands])
    data[name] = frames
    print(name, len(frames), f"cpu {time.process_time()-t:.0f}s", flush=True)
if "renders" in sets:
    from foos_vision.still_renders import still_render_set
    frames = []
    t = time.process_time()
    for camera_name, seed, colour, image, truth in still_render_set():
        field, cands = finder.find(image)
        frames.append((f"{camera_name}{seed}-{colour}", truth,
                       None if field is None else field.ball_radius_px, [light(c) for c in cands]))
    data["renders"] = frames
    print("renders", len(frames), f"cpu {time.process_time()-t:.0f}s", flush=True)
pickle.dump(data, open(out, "wb"))
