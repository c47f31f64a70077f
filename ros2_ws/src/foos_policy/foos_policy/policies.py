"""Finding and loading policies: shipped ones by name, saved SB3 zips by path, and the baselines."""
from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import Optional

import numpy as np
from ament_index_python.packages import PackageNotFoundError, get_package_share_directory

from foos_core.names import COMMAND_SIZE
from foos_core.table_params import load_params
from foos_sim import command_limits as params_command_limits

from .actions import ScriptedResidual, action_map, action_mode_of
from .decisions import DECISION_PERIOD_DEFAULT, HeldDecision
from .observation import ACTION_LIMIT, OBS_SCALE, observes_scaled, scaled_observation
from .scripted import ScriptedPolicy

BASELINES = ("zero", "random", "scripted", "lift-ahead")


class PolicyError(ValueError):
    """A policy that cannot be found or loaded; the message is one line for the user."""


def shipped_dirs() -> list[Path]:
    """Where shipped policies live: the installed share directory, then the source tree."""
    dirs = []
    try:
        dirs.append(Path(get_package_share_directory("foos_policy")) / "policies")
    except (PackageNotFoundError, OSError):  # not installed, or no workspace sourced: the source tree still has them
        pass
    dirs.append(Path(__file__).resolve().parents[1] / "policies")
    return [d for d in dirs if d.is_dir()]


def shipped_policies() -> list[str]:
    names = set()
    for d in shipped_dirs():
        names.update(p.stem for p in d.glob("*.zip"))
    return sorted(names)


def resolve_policy(spec: str) -> Path:
    """A path to a .zip, or the name of a shipped policy (e.g. sac_hardened_scripted_s0)."""
    path = Path(spec).expanduser()
    if path.suffix == ".zip" or path.exists():
        if not path.is_file():
            raise PolicyError(f"policy file {path} does not exist")
        return path
    for d in shipped_dirs():
        candidate = d / f"{spec}.zip"
        if candidate.is_file():
            return candidate
    available = ", ".join(shipped_policies()) or "none"
    raise PolicyError(f"no policy named `{spec}` (shipped: {available}; or give a PATH.zip)")


def algo_of(path: Path) -> tuple[str, str]:
    """(learner, algo): 'sbx' (JAX) or 'sb3' (torch), and 'sac' or 'tqc', read from the policy class a saved zip
    records."""
    try:
        with zipfile.ZipFile(path) as z:
            data = json.loads(z.read("data"))
    except (zipfile.BadZipFile, KeyError, json.JSONDecodeError, OSError) as exc:
        raise PolicyError(f"{path} is not a saved SB3/SBX model ({exc.__class__.__name__})") from None
    module = str(data.get("policy_class", {}).get("__module__", ""))
    learner = "sbx" if module.startswith("sbx.") else "sb3"
    for algo in ("tqc", "sac"):
        if algo in module:
            return learner, algo
    raise PolicyError(f"{path} holds a `{module or 'unknown'}` policy; only SAC and TQC are supported")


def algorithm_class(learner: str, algo: str):
    """(class, device) of SAC or TQC from SBX ('sbx', JAX) or SB3 / sb3-contrib ('sb3', torch): the one place
    train, load_model and bench_policy pick a learner."""
    # The learners are imported here, not at the top: JAX and torch take seconds to import, and a command's
    # --help need not wait.
    if learner == "sbx":
        from sbx import SAC, TQC  # JAX: seconds to import; reads XLA_FLAGS then

        return (TQC if algo == "tqc" else SAC), "auto"
    if algo == "tqc":
        from sb3_contrib import TQC  # torch: seconds to import

        return TQC, "cpu"
    from stable_baselines3 import SAC  # torch: seconds to import

    return SAC, "cpu"


def load_model(spec: str | Path):
    path = resolve_policy(str(spec))
    Algo, device = algorithm_class(*algo_of(path))
    try:
        return Algo.load(path, device=device)
    except Exception as exc:  # a damaged zip fails in many ways inside SB3/SBX
        raise PolicyError(f"cannot load {path}: {exc}".splitlines()[0]) from None


class Policy:
    """An own-view controller: predict(obs) -> the paper's velocity action in [-20, 20]^8."""

    name = "policy"

    def predict(self, obs: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def reset(self) -> None:
        """A new episode begins: forget anything held from the last one (a held decision)."""


class ZeroPolicy(Policy):
    name = "zero"

    def predict(self, obs):
        return np.zeros(COMMAND_SIZE, np.float32)


class RandomPolicy(Policy):
    name = "random"

    def __init__(self, seed: int = 0):
        self.rng = np.random.default_rng(seed)

    def predict(self, obs):
        return self.rng.uniform(-ACTION_LIMIT, ACTION_LIMIT, COMMAND_SIZE).astype(np.float32)


class ScriptedBaseline(Policy):
    name = "scripted"

    def __init__(self, params: dict, command_limits):
        self.policy = ScriptedPolicy(params, command_limits)

    def predict(self, obs):
        return self.policy.predict(obs)


class LiftAheadBaseline(Policy):
    """The lift-ahead base of the corrections (foos_policy.scripted) with no correction: the scripted controller's
    tracking and kicks, its hold on the braking curve, and its rods ahead of the ball raised back."""

    name = "lift-ahead"

    def __init__(self, params: dict, command_limits):
        self.base = ScriptedResidual(params, command_limits, "lift-ahead")

    def predict(self, obs):
        return self.base.velocity_action(obs, np.zeros(COMMAND_SIZE))


class ModelPolicy(Policy):
    """A trained SAC/TQC model. One trained on position targets or on corrections to the scripted controller (its
    action box says which) is followed by what turns them into velocity actions on the table `params` describes."""

    def __init__(self, spec: str | Path, params: Optional[dict] = None, command_limits=None):
        self.path = resolve_policy(str(spec))
        self.name = self.path.stem
        self.model = load_model(self.path)
        try:
            self.action_mode = action_mode_of(self.model.action_space.high)
            self.observes_scaled = observes_scaled(self.model.observation_space)
        except ValueError as exc:
            raise PolicyError(f"{self.path}: {exc}") from None
        saved_scale = getattr(self.model, "observation_scale", None)
        if self.observes_scaled and (saved_scale is None or not np.allclose(saved_scale, OBS_SCALE)):
            raise PolicyError(f"{self.path}: trained on a scaled observation with scales {saved_scale}, not this version's "
                              f"foos_policy.observation.OBS_SCALE")
        # models saved before the lift-ahead base existed carry no base: theirs was the scripted controller
        self.residual_base = getattr(self.model, "residual_base", "scripted")
        try:
            self.action_map = action_map(self.action_mode, *_table(params, command_limits), self.residual_base)
        except ValueError as exc:
            raise PolicyError(f"{self.path}: {exc}") from None
        # a model trained with `train --decision-period K` chose an action every K control steps and held it
        # (foos_policy.decisions); older models carry none and chose every step
        try:
            self.decision = HeldDecision(getattr(self.model, "decision_period", DECISION_PERIOD_DEFAULT))
        except ValueError as exc:
            raise PolicyError(f"{self.path}: {exc}") from None
        self.held = None

    def reset(self) -> None:
        self.decision.reset()

    def predict(self, obs):
        obs = np.asarray(obs, np.float32)
        if self.decision.due():
            self.held, _ = self.model.predict(scaled_observation(obs) if self.observes_scaled else obs, deterministic=True)
        action = self.held
        if self.action_map is not None:
            return self.action_map.velocity_action(obs, action)
        return np.clip(action, -ACTION_LIMIT, ACTION_LIMIT).astype(np.float32)


def make_policy(spec: str, params: Optional[dict] = None, command_limits=None, seed: int = 0) -> Policy:
    """The policy `spec` names; the scripted baseline plays the table `params` describe (nominal by default)
    with the drives' `command_limits` (those of `params` by default)."""
    if spec == "zero":
        return ZeroPolicy()
    if spec == "random":
        return RandomPolicy(seed)
    if spec == "scripted":
        return ScriptedBaseline(*_table(params, command_limits))
    if spec == "lift-ahead":
        return LiftAheadBaseline(*_table(params, command_limits))
    return ModelPolicy(spec, params, command_limits)


def _table(params: Optional[dict], command_limits) -> tuple[dict, np.ndarray]:
    """The table a controller plays (the nominal one by default) and its drives' command limits (those of the table
    by default)."""
    params = load_params() if params is None else params
    return params, params_command_limits(params) if command_limits is None else command_limits
