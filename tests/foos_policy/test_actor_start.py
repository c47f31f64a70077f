"""`train --actor-start zero` and `--gamma`: the actor's mean starts at the action box's centre (for corrections,
the scripted controller's own play) with a small spread, on both learners, and the discount reaches the learner."""
from pathlib import Path

import numpy as np
import pytest

from foos_policy.env import FoosballEnv
from foos_policy.train import ZERO_START_STD, build_model, parse_args


def _model(tmp_path: Path, learner: str, algo: str, start: str):
    args = parse_args(["--algo", algo, "--learner", learner, "--action", "residual", "--actor-start", start,
                       "--learning-starts", "0", "--gamma", "0.95", "--reset", "hardened", "--opponent", "scripted",
                       "--out", str(tmp_path)])
    env = FoosballEnv(reset="hardened", opponent="scripted", action="residual")
    return build_model(args, env, tmp_path / "tb"), env


@pytest.mark.timeout(300)
@pytest.mark.parametrize("learner, algo", [("sbx", "sac"), ("sb3", "tqc")])
def test_a_zero_start_acts_at_the_centre_with_a_small_spread(tmp_path, learner, algo):
    observations = np.random.default_rng(0).normal(0.0, 0.5, (16, 36)).astype(np.float32)
    model, env = _model(tmp_path, learner, algo, "zero")
    assert model.gamma == 0.95
    mean, _ = model.predict(observations, deterministic=True)
    assert np.abs(mean).max() < 1e-6
    draws = np.stack([model.predict(observations[0], deterministic=False)[0] for _ in range(300)]) / env.action_space.high
    # tanh of N(0, 0.2): a spread of about 0.2 of the bound, not the default start's near-uniform one
    assert np.all(np.abs(draws.std(axis=0) - ZERO_START_STD) < 0.05)
    default, _ = _model(tmp_path / "default", learner, algo, "default")
    assert np.abs(default.predict(observations, deterministic=True)[0]).max() > 1e-3  # the check can fail


def test_a_discount_outside_zero_to_one_is_refused(capsys):
    with pytest.raises(SystemExit):
        parse_args(["--gamma", "1.5", "--out", "x"])
    assert "--gamma must be in (0, 1]" in capsys.readouterr().err.strip().splitlines()[-1]
