"""The SBX actor's pre-tanh means and standard deviations on the states a saved residual model visits.

usage: python actor_saturation.py MODEL.zip raw|scaled
Plays 3 hardened episodes (seeds 100-102) on the robot table against the scripted opponent and prints, per action
dimension, the median |pre-tanh mean|, the share above 2 (tanh 0.96: the correction at its bound) and the median
log standard deviation. `scaled` feeds the network the scaled view it was trained on."""
import sys

import jax.numpy as jnp
import numpy as np

from foos_core.table_params import ROBOT_PARAMS_FILE
from foos_policy.env import FoosballEnv
from foos_policy.observation import scaled_observation
from foos_policy.policies import load_model

model = load_model(sys.argv[1])
view = scaled_observation if sys.argv[2] == "scaled" else (lambda o: np.asarray(o, np.float32))
env = FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_PARAMS_FILE), action="residual")
seen = []
for episode in range(3):
    obs, _ = env.reset(seed=100 + episode)
    for _ in range(300):
        seen.append(view(obs))
        action, _ = model.predict(view(obs), deterministic=True)
        obs, _, terminated, truncated, _ = env.step(action)
        if terminated or truncated:
            break
gaussian = model.policy.actor.apply(model.policy.actor_state.params, jnp.asarray(np.array(seen))).distribution
mean, log_std = np.asarray(gaussian.loc), np.log(np.asarray(gaussian.stddev()))
print("observation as fed, |max| per dim", np.round(np.abs(np.array(seen)).max(0), 1))
print("median |pre-tanh mean|", np.round(np.median(np.abs(mean), 0), 2))
print("share |pre-tanh mean| > 2", np.round((np.abs(mean) > 2).mean(0), 2))
print("median log std", np.round(np.median(log_std, 0), 2))
