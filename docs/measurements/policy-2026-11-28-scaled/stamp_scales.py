# The runs started before train saved the scales: stamp the same OBS_SCALE they were trained with (observation.py unchanged since)
import sys
from foos_policy.observation import OBS_SCALE
from foos_policy.policies import load_model
for path in sys.argv[1:]:
    m = load_model(path); m.observation_scale = OBS_SCALE.tolist(); m.save(path); print("stamped", path)
