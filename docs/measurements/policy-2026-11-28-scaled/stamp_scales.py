"""Stamp OBS_SCALE on models trained with `--observation scaled` before train saved the scales with the model.

These runs started minutes before that change; observation.py's scales did not change between, so the stamp is what
they were trained with. usage: python stamp_scales.py MODEL.zip ..."""
import sys

from foos_policy.observation import OBS_SCALE
from foos_policy.policies import load_model

for path in sys.argv[1:]:
    model = load_model(path)
    model.observation_scale = OBS_SCALE.tolist()
    model.save(path)
    print("stamped", path)
