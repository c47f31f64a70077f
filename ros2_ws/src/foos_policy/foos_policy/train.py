"""`ros2 run foos_policy train`: SAC or TQC on the foosball env, with the paper's metrics and figures."""
from __future__ import annotations

import argparse
import json
import os
import signal
import sys
import time
from pathlib import Path

import gymnasium as gym
import numpy as np
from tqdm import tqdm

from foos_sim.drive_profiles import drive_kind

from .actions import ACTION_MODES
from .commands import add_task_arguments, check_task_arguments, run_command, write_json
from .curriculum import stage_at, stages
from .decisions import DecisionPeriod, check_decision_period
from .env import make_env
from .metrics import MetricsWriter, plot_metrics, summarize_tail
from .observation import OBS_SCALE, OBS_SCALED_BOUND, OBS_SIZE, scaled_observation
from .policies import algorithm_class
from .scripted import RESIDUAL_BASES
from .tasks import REWARDS, make_reward

ZERO_START_STD = 0.2  # --actor-start zero: the spread before the tanh (a correction's first draws within about a fifth of its bound)

DESCRIPTION = """\
Train SAC or TQC for the home team on the foosball twin: SBX (JAX) by default, or stable-baselines3 /
sb3-contrib (torch, the paper's) with --learner sb3.

The env is the paper's task: 36-D observation, 8-D action in [-20, 20], control at 50 Hz over the table's
physics (the fast physics unless the table's parameter file names the 20 kHz reference), episodes ending on
a goal, 1 s of stagnant ball, or 10 s. The reward is the paper's (--reward paper) or the skill reward
(--reward skill); --curriculum puts a resting ball and still away rods first.

Writes into --out DIR:
  NAME.zip         the trained policy (NAME = ALGO_RESET_OPPONENT_sSEED unless --name), no replay buffer
  metrics.csv      one row per episode: return, length, win, lose, term_goal, touches, ..., the paper's
                   50-episode Return50, EpLen50, WinRate50, LoseRate50, TermGoal50, wall_s and stage
  figures/*.png    smoothed return, episode length, win/lose/goal-termination rates, return vs length, and
                   learning_curve.png (win and own-goal rates against steps and wall-clock)
  checkpoints/     intermediate models every --checkpoint-every steps
  tb/              TensorBoard logs (tensorboard --logdir DIR/tb)
  run.json         the command line, learner set-up, budget, wall time and steps/s of this run
Ctrl-C stops early and still saves the model, metrics and figures.

Examples:
  ros2 run foos_policy train --algo sac --steps 20000 --reset hardened --opponent scripted --seed 0 --out runs/sac_h_s0
  ros2 run foos_policy train --algo tqc --reward skill --curriculum --reset hardened --opponent scripted \
      --steps 2000000 --time-limit 45 --seed 0 --out runs/tqc_h_s0      # how the shipped policies were trained
"""


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="train", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--algo", choices=("sac", "tqc"), default="sac", help="learning algorithm (default sac)")
    p.add_argument("--learner", choices=("sbx", "sb3"), default="sbx",
                   help="sbx: the JAX SAC/TQC (sbx-rl), 3.8x SB3's env steps/s here at one update per step; sb3: stable-baselines3 / "
                        "sb3-contrib on torch, the paper's (default sbx; docs/policy.md has the comparison)")
    p.add_argument("--reward", choices=REWARDS, default="paper",
                   help="paper: progress + distance shaping + 1000 per goal; skill: signed progress, a first-touch bonus "
                        "and 10 per goal, own goals -10 (default paper)")
    p.add_argument("--own-goal-penalty", type=float, default=None, metavar="R",
                   help="the skill reward's penalty for a goal conceded (default 10, as a goal scored); higher trades "
                        "shots for safety")
    p.add_argument("--spin-penalty", type=float, default=None, metavar="R",
                   help="put the skill reward under the tournament rule on spins (foos_policy.spins): each home touch by a "
                        "rod that had turned over 360 degrees one way costs R, and a goal off one pays nothing (default: "
                        "spins are free)")
    p.add_argument("--curriculum", action="store_true",
                   help="train first on a resting ball with still away rods (15 %% of the budget), then the task's serve "
                        "with still away rods (15 %%), then the task itself")
    p.add_argument("--action", choices=ACTION_MODES, default="velocity",
                   help="velocity: the paper's 8-D action in [-20, 20], a share of each drive's speed limit; position: "
                        "rod position targets in [-1, 1]^8 (slide a share of the travel, rotation a share of pi) that a "
                        "braking-curve controller follows (foos_policy.actions; policy_node still publishes velocities); "
                        "residual: corrections to the scripted controller's targets in [-0.04, 0.04] m (slides) and "
                        "[-pi/2, pi/2] rad (the angle the figures are held at, on the braking curve); kicks stay the "
                        "scripted controller's (default velocity)")
    p.add_argument("--residual-base", choices=RESIDUAL_BASES, default="scripted",
                   help="what --action residual corrects: scripted, the scripted controller; lift-ahead, the same with its "
                        "rods ahead of the ball holding their feet raised back (foos_policy.scripted; 0.30 win, 0.09 own goals "
                        "with zero corrections on the hardened robot task). Saved with the model (default scripted)")
    p.add_argument("--observation", choices=("raw", "scaled"), default="raw",
                   help="what the network sees: raw, the 36-D observation in SI units (rod spins up to 314 rad/s beside "
                        "positions under 1 m), or scaled, each quantity divided by a typical size and clipped at +-5 "
                        "(foos_policy.observation.OBS_SCALE). The saved model's observation box says which, so evaluate "
                        "and policy_node feed it the same view (default raw, as the shipped policies)")
    p.add_argument("--action-cost", type=float, default=0.0, metavar="C",
                   help="a cost each step of C times the mean squared action, each entry a share of its bound, meant to "
                        "pull corrections (--action residual) toward zero, the scripted controller's own play; at 0.05 "
                        "one SAC seed's corrections stayed at 0.7 of their bounds (docs/measurements/"
                        "policy-2026-11-28-residual.md) (default 0)")
    p.add_argument("--decision-period", type=int, default=1, metavar="K",
                   help="control steps (20 ms each) the learner's action is held for: the learner decides every K steps, "
                        "its reward the sum over them, --gamma and --steps per decision, while the scripted base under "
                        "corrections or the controller under position targets still acts every step (foos_policy.decisions). "
                        "Saved with the model, so evaluate and policy_node hold its actions alike (default 1)")
    p.add_argument("--steps", type=int, default=20000,
                   help="environment steps to train (default 20000; SBX SAC learns at ~330 steps/s on a free core)")
    add_task_arguments(p)
    p.add_argument("--seed", type=int, default=0, help="seed of the env, the network init and the exploration (default 0)")
    p.add_argument("--out", required=True, help="output directory (created; files in it are overwritten)")
    p.add_argument("--name", default=None, help="file stem of the saved policy (default ALGO_RESET_OPPONENT_sSEED)")
    p.add_argument("--n-envs", type=int, default=1, help="vectorised envs stepped together (DummyVecEnv, default 1)")
    p.add_argument("--net", type=int, nargs="+", default=[64, 64], help="hidden layer sizes of actor and critics (default 64 64)")
    p.add_argument("--learning-starts", type=int, default=1000, help="random steps before learning (default 1000)")
    p.add_argument("--train-freq", type=int, default=32,
                   help="env steps (per env) between rounds of updates (default 32: one round of --gradient-steps per 32)")
    p.add_argument("--gradient-steps", type=int, default=32,
                   help="gradient steps per round (default 32: one update per env step, as the paper; docs/policy.md)")
    p.add_argument("--buffer-size", type=int, default=200_000, help="replay buffer size (default 200000)")
    p.add_argument("--checkpoint-every", type=int, default=5000, help="steps between checkpoints (default 5000)")
    p.add_argument("--time-limit", type=float, default=0.0,
                   help="stop after this many wall-clock minutes even if --steps is not reached (0 = no limit); "
                        "run.json records the steps actually done")
    p.add_argument("--ent-coef", type=_entropy_coefficient, default="auto", metavar="auto|C",
                   help="SAC/TQC's entropy coefficient: auto (tuned to a target entropy, the default) or a fixed C >= 0 "
                        "(on corrections, --action residual, 0.001 left the actions at 0.7 of their bounds as auto did)")
    p.add_argument("--gamma", type=float, default=0.99,
                   help="the critic's discount per 20 ms control step: 0.99 looks about 2 s ahead, 0.95 about 0.4 s, "
                        "the outcome of the next touch rather than of the rally (default 0.99)")
    p.add_argument("--actor-start", choices=("default", "zero"), default="default",
                   help="default: the learner's own initialisation (a random mean, a spread of about 1 before the tanh); "
                        "zero: the actor's mean output starts at zero for every observation, with a spread of "
                        f"{ZERO_START_STD} before the tanh, so with --action residual the first episodes play the scripted "
                        "controller's own game, not a random one; give --learning-starts 0 as well, or the first steps are "
                        "uniform random actions (default default)")
    p.add_argument("--threads", type=int, default=1, help="torch (sb3) or XLA (sbx) threads (default 1: the CPU is shared)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    args = p.parse_args(argv)
    if args.steps <= 0:
        p.error("--steps must be positive")
    if not args.action_cost >= 0:
        p.error(f"--action-cost must be at least 0, got {args.action_cost}")
    if args.n_envs <= 0 or args.train_freq <= 0 or args.gradient_steps <= 0:
        p.error("--n-envs, --train-freq and --gradient-steps must be positive")
    if not 0 < args.gamma <= 1:
        p.error(f"--gamma must be in (0, 1], got {args.gamma}")
    try:
        check_decision_period(args.decision_period)
    except ValueError as problem:
        p.error(str(problem))
    if args.residual_base != "scripted" and args.action != "residual":
        p.error(f"--residual-base {args.residual_base} needs --action residual")
    check_task_arguments(p, args)
    try:  # the reward's own check, before any env is made
        make_reward(args.reward, args.own_goal_penalty, args.spin_penalty)
    except ValueError as problem:
        p.error(str(problem))
    return args


def _entropy_coefficient(text: str):
    if text == "auto":
        return text
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be auto or a number, got '{text}'") from None
    if not value >= 0:
        raise argparse.ArgumentTypeError(f"must be at least 0, got {text}")
    return value


class ScaledObservation(gym.ObservationWrapper):
    """What the learner sees with `--observation scaled`: the env (and its action map) keeps the raw observation.
    The bounded box is saved with the model, so evaluate and policy_node scale what they feed it too."""

    def __init__(self, env):
        super().__init__(env)
        self.observation_space = gym.spaces.Box(-OBS_SCALED_BOUND, OBS_SCALED_BOUND, (OBS_SIZE,), np.float32)

    def observation(self, observation):
        return scaled_observation(observation)


def default_name(algo: str, reset: str, opponent: str, seed: int) -> str:
    return f"{algo}_{reset}_{opponent}_s{seed}"


def build_model(args, env, tb_dir: Path):
    """The learner: SBX (JAX) or SB3 (torch) SAC or TQC, with the update schedule of the arguments."""
    kwargs = dict(
        policy="MlpPolicy", env=env, seed=args.seed, verbose=0,
        learning_starts=args.learning_starts, buffer_size=args.buffer_size, batch_size=256,
        train_freq=args.train_freq, gradient_steps=args.gradient_steps,
        tensorboard_log=str(tb_dir), policy_kwargs=dict(net_arch=list(args.net)), ent_coef=args.ent_coef, gamma=args.gamma,
    )
    if args.learner == "sbx" and args.threads == 1:  # read by XLA when JAX loads: one thread, so two runs share the cores
        os.environ.setdefault("XLA_FLAGS", "--xla_cpu_multi_thread_eigen=false intra_op_parallelism_threads=1")
    Algo, device = algorithm_class(args.learner, args.algo)
    if args.learner == "sb3":
        import torch  # loaded already by algorithm_class

        torch.set_num_threads(args.threads)
        kwargs["device"] = device
    model = Algo(**kwargs)
    if args.actor_start == "zero":
        start_actor_at_zero(model, args.learner)
    return model


def start_actor_at_zero(model, learner: str) -> None:
    """Zero the weights of the actor's mean head, so the mean is 0 (the action box's centre) for every
    observation, and set its spread head to a constant log std. Why: on corrections (--action residual) the learner
    otherwise starts from a random mean and random first steps, far from the scripted play it is meant to correct;
    last session's actors sat at 0.7 of their bounds from the start (docs/measurements/policy-2026-11-28-scaled.md)."""
    log_std = float(np.log(ZERO_START_STD))
    if learner == "sb3":
        import torch  # loaded already by algorithm_class

        with torch.no_grad():
            model.actor.mu.weight.zero_()
            model.actor.mu.bias.zero_()
            model.actor.log_std.weight.zero_()
            model.actor.log_std.bias.fill_(log_std)
        return
    # SBX's actor (flax): its last two Dense layers are the mean head, then the log-std head
    state = model.policy.actor_state
    params = state.params["params"]
    dense = sorted((k for k in params if k.startswith("Dense_")), key=lambda k: int(k.split("_")[1]))
    mean_head, std_head = dense[-2], dense[-1]
    new = dict(params)
    new[mean_head] = {k: np.zeros_like(v) for k, v in params[mean_head].items()}
    new[std_head] = {"kernel": np.zeros_like(params[std_head]["kernel"]),
                     "bias": np.full_like(params[std_head]["bias"], log_std)}
    model.policy.actor_state = state.replace(params={**state.params, "params": new})


def make_callbacks(metrics, total: int, progress: bool, checkpoint_dir: Path, checkpoint_every: int, name: str, n_envs: int,
                   time_limit_s: float = 0.0, curriculum=()):
    # torch: seconds to import
    from stable_baselines3.common.callbacks import BaseCallback, CallbackList, CheckpointCallback

    class EpisodeMetrics(BaseCallback):
        """Writes a metrics.csv row for every finished episode and logs it to TensorBoard."""

        def _on_step(self) -> bool:
            for info in self.locals.get("infos", []):
                stats = info.get("episode_stats")
                if stats is None:
                    continue
                metrics.add(self.num_timesteps, stats)
                for key in ("return", "length", "win", "lose", "term_goal", "touches"):
                    self.logger.record_mean(f"episode/{key}", float(stats[key]))
            return True

    class Progress(BaseCallback):
        def _on_training_start(self) -> None:
            self.bar = tqdm(total=total, unit="step", desc=name, smoothing=0.05, disable=not progress, mininterval=2.0)
            self.start = time.time()

        def _on_step(self) -> bool:
            self.bar.update(self.training_env.num_envs)
            if metrics.episodes and self.n_calls % 200 == 0:
                self.bar.set_postfix(episodes=metrics.episodes)
            # the wall-clock budget: stop learning, keep everything learnt so far
            return not (time_limit_s > 0 and time.time() - self.start > time_limit_s)

        def _on_training_end(self) -> None:
            self.bar.close()

    class Curriculum(BaseCallback):
        """Moves every env to the stage the budget spent so far calls for (from their next episode on)."""

        def _on_training_start(self) -> None:
            self.start = time.time()
            self.stage = None

        def _on_step(self) -> bool:
            spent = self.num_timesteps / total
            if time_limit_s > 0:
                spent = max(spent, (time.time() - self.start) / time_limit_s)
            stage = stage_at(curriculum, spent)
            if stage != self.stage:
                self.training_env.env_method("set_task", stage.reset, stage.opponent)
                self.stage = stage
            return True

    checkpoints = CheckpointCallback(save_freq=max(checkpoint_every // n_envs, 1), save_path=str(checkpoint_dir), name_prefix=name)
    return CallbackList([Curriculum(), EpisodeMetrics(), Progress(), checkpoints])


def train(args) -> dict:
    from stable_baselines3.common.vec_env import DummyVecEnv  # torch: seconds to import

    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    name = args.name or default_name(args.algo, args.reset, args.opponent, args.seed)

    curriculum = stages(args.reset, args.opponent, args.curriculum)
    first = curriculum[0]  # the envs start on the first stage: their first episode begins before any callback runs

    def env_factory(rank: int):
        def make():
            env = make_env(first.reset, first.opponent, args.opponent_policy, reward=args.reward, own_goal_penalty=args.own_goal_penalty,
                           spin_penalty=args.spin_penalty, opponent_delay=args.opponent_delay,
                           view=args.view, opponent_view=args.opponent_view, params_file=args.params_file, action=args.action,
                           residual_base=args.residual_base, action_cost=args.action_cost)
            if args.observation == "scaled":
                env = ScaledObservation(env)
            env = DecisionPeriod(env, args.decision_period)  # K = 1: one control step a decision, as before
            env.reset(seed=args.seed * 1000 + rank)
            return env
        return make

    env = DummyVecEnv([env_factory(i) for i in range(args.n_envs)])
    env.seed(args.seed)
    model = build_model(args, env, out / "tb")
    if args.observation == "scaled":  # saved with the model: ModelPolicy refuses a model scaled otherwise than today
        model.observation_scale = OBS_SCALE.tolist()
    if args.action == "residual":  # saved with the model: what its corrections act on (ModelPolicy reads it back)
        model.residual_base = args.residual_base
    model.decision_period = args.decision_period  # saved with the model: ModelPolicy holds its actions as long
    metrics = MetricsWriter(out / "metrics.csv")
    callbacks = make_callbacks(metrics, args.steps, not args.no_progress, out / "checkpoints", args.checkpoint_every, name, args.n_envs,
                               args.time_limit * 60.0, curriculum)

    interrupted = False

    def on_sigterm(signum, frame):
        raise KeyboardInterrupt

    signal.signal(signal.SIGTERM, on_sigterm)
    start = time.time()
    try:
        model.learn(total_timesteps=args.steps, callback=callbacks, tb_log_name=name)
    except KeyboardInterrupt:
        interrupted = True
    wall = time.time() - start
    metrics.close()
    model_path = out / f"{name}.zip"
    model.save(model_path)
    summary = {
        "name": name, "algo": args.algo, "reset": args.reset, "opponent": args.opponent, "seed": args.seed,
        "steps_requested": args.steps, "time_limit_min": args.time_limit, "steps_done": int(model.num_timesteps),
        "interrupted": interrupted, "wall_s": round(wall, 1), "steps_per_s": round(model.num_timesteps / max(wall, 1e-9), 1),
        "learner": args.learner, "reward": args.reward, "own_goal_penalty": args.own_goal_penalty,
        "spin_penalty": args.spin_penalty, "curriculum": args.curriculum,
        "view": args.view, "opponent_view": args.opponent_view, "opponent_delay": args.opponent_delay,
        # the drives trained on: since 29 Nov the default table's are a robot's, so params_file None alone no longer says
        "params_file": args.params_file, "drive": drive_kind(env.envs[0].unwrapped.sim.params),
        "action": args.action, "observation": args.observation,
        "residual_base": args.residual_base if args.action == "residual" else None,
        "decision_period": args.decision_period,
        "control_steps_done": sum(e.control_steps for e in env.envs),
        "ent_coef": args.ent_coef, "action_cost": args.action_cost, "gamma": args.gamma, "actor_start": args.actor_start,
        "train_freq": args.train_freq, "gradient_steps": args.gradient_steps,
        "net": list(args.net), "n_envs": args.n_envs, "control_rate_hz": 50.0,
        "command": "train " + " ".join(sys.argv[1:]) if sys.argv else "",
        "model": str(model_path),
    }
    if metrics.episodes:
        plot_metrics(out / "metrics.csv", out / "figures", title=name)
        summary["final"] = summarize_tail(out / "metrics.csv")
    write_json(out / "run.json", summary)
    return summary


def main(argv=None) -> int:
    args = parse_args(argv)
    summary = run_command("train", lambda: train(args), (ValueError, OSError),
                          interrupted="interrupted before the model existed; nothing saved")
    print(json.dumps({k: summary[k] for k in ("name", "steps_done", "wall_s", "steps_per_s", "model")}))
    if "final" in summary:
        print(json.dumps(summary["final"]))
    return 130 if summary["interrupted"] else 0


if __name__ == "__main__":
    sys.exit(main())
