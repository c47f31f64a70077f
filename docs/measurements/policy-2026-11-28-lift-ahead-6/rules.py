"""The hand rules tried on 28 Nov before the lift-ahead base was chosen (policy-2026-11-28-lift-ahead-6.md): the scripted
plan with its hold on the braking curve (as foos_policy.actions.ScriptedResidual) plus
  (a) the own rods ahead of the ball lifted (feet forward +1.4 or back -1.4),
  (b) a back kick for a slow ball behind a rod's axis: clear sideways, raise the feet back, align, swing forward,
  (c) an aim: the attack's slide offset so the foot strikes the ball off centre, toward the side of the goal the
      opponent's goalie leaves open, or a fixed slide offset for every rod.
Robot table, hardened reset, scripted opponent, camera loop, the first N episodes of seed 7:

    python tactical.py base [N]     # lift -1.4 alone, with the back kick, with the back kick raised to -1.0
    python tactical.py aim [N]      # lift -1.4 with an aim of 10 or 20 mm, or all slides +20 mm

Run in a shell that sourced scripts/env.sh. `counts`: steps in the back kick's clearing phase, kicks, unused."""
import sys
import time

import numpy as np

from foos_core.names import RODS
from foos_core.table_params import ROBOT_PARAMS_FILE
from foos_policy.actions import LEAD_S, PositionTargets
from foos_policy.env import make_env
from foos_policy.evaluation import episode_seeds, run_episodes, summarize
from foos_policy.observation import ACTION_LIMIT, OWN_SLOT, wrap_angle
from foos_policy.scripted import SLIDE_GAIN, ScriptedPolicy, own_rod_geometry

SEEDS = episode_seeds(7, int(sys.argv[2]) if len(sys.argv) > 2 else 100)

class Tactical:
    def __init__(self, params, limits, margin=0.04, lift=1.4, back=True, back_reach=0.065, back_speed=0.3,
                 raised=-1.3, clear=0.045, align=0.012, lift_ahead=True, aim=0.0, aim_rods=('attack',), slide=0.0):
        self.s = ScriptedPolicy(params, limits)
        self.hold = PositionTargets(params, limits)
        self.limits = np.asarray(limits, float)
        self.g = own_rod_geometry(params)
        self.slots = np.array([OWN_SLOT[r] for r in RODS])
        self.__dict__.update(margin=margin, lift=lift, back=back, back_reach=back_reach, back_speed=back_speed,
                             raised=raised, clear=clear, align=align, lift_ahead=lift_ahead, aim=aim, aim_rods=aim_rods, slide=slide)
        self.count = np.zeros(3)

    def __call__(self, obs):
        obs = np.asarray(obs, float)
        command, kicking = self.s.plan(obs)
        bx, by, bvx, bvy = obs[:4]
        slow = np.hypot(bvx, bvy) < self.back_speed
        rods = obs[4:].reshape(8, 4)[self.slots]
        hold = np.zeros(4)
        gx = obs[4 + 4 * 7]
        open_x = -0.06 if gx > 0 else 0.06
        for r, rod in enumerate(RODS):
            if not kicking[r]:
                off = self.slide
                if rod in self.aim_rods and self.aim:
                    off += -self.aim * np.sign(open_x - bx)
                command[2 * r] += SLIDE_GAIN * off
        for r, rod in enumerate(RODS):
            g = self.g[rod]
            slide, _, angle, _ = rods[r]
            behind = g.y - by
            if self.back and slow and 0.0 < behind < self.back_reach and not kicking[r]:
                xs = np.array(g.offsets) + slide
                f = int(np.argmin(np.abs(bx - xs)))
                dx = bx - xs[f]
                a = wrap_angle(angle)
                if a > self.raised + 0.4:      # not raised yet: get clear sideways, then raise
                    if abs(dx) < self.clear:
                        side = -1.0 if dx >= 0 else 1.0   # move the figure to the other side of the ball
                        target = np.clip(bx + side * (self.clear + 0.01) - g.offsets[f], -g.travel, g.travel)
                        command[2 * r] = SLIDE_GAIN * (target - slide)
                        hold[r] = 0.0
                    else:
                        command[2 * r] = 0.0
                        hold[r] = self.raised
                    self.count[0] += 1
                else:                          # raised: align, then swing through
                    target = np.clip(bx - g.offsets[f], -g.travel, g.travel)
                    command[2 * r] = SLIDE_GAIN * (target - slide)
                    hold[r] = self.raised
                    if abs(dx) < self.align:
                        command[2 * r + 1] = self.limits[2 * r + 1]
                        kicking[r] = True
                        self.count[1] += 1
                continue
            if self.lift_ahead and g.y > by + self.margin and not kicking[r]:
                hold[r] = self.lift
        error = wrap_angle(hold - (rods[:, 2] + LEAD_S * rods[:, 3]))
        hv = np.sign(error) * self.hold.braking_speed(np.repeat(np.abs(error), 2))[1::2]
        command[1::2] = np.where(kicking, command[1::2], hv)
        command = np.clip(command, -self.limits, self.limits)
        return (command / self.limits * ACTION_LIMIT).astype(np.float32)

def run(name, **kw):
    env = make_env("hardened", "scripted", None, params_file=str(ROBOT_PARAMS_FILE))
    pol = Tactical(env.sim.params, env.sim.command_limits, **kw)
    t = time.time()
    s = summarize(run_episodes(env, pol, SEEDS))
    print(f"{name:34s} win {s['win_rate']:.2f} legal {s['win_rate_without_spins']:.2f} own {s['own_goal_rate']:.2f} "
          f"lost {s.get('loss_rate', float('nan')):.2f} stagnant {s['stagnant_rate']:.2f} touches {s['touches']:.1f} "
          f"len {s['mean_length']:.0f} counts {pol.count.astype(int).tolist()} ({time.time()-t:.0f} s)", flush=True)
    return s

if __name__ == "__main__":
    which = sys.argv[1]
    if which == "base":
        run("lift -1.4 only", back=False, lift=-1.4)
        run("lift -1.4 + back kick", lift=-1.4)
        run("lift -1.4 + back kick raised -1.0", lift=-1.4, raised=-1.0)
    elif which == "aim":
        run("lift, aim attack 10 mm", back=False, lift=-1.4, aim=0.01)
        run("lift, aim attack 20 mm", back=False, lift=-1.4, aim=0.02)
        run("lift, aim attack+mid 20 mm", back=False, lift=-1.4, aim=0.02, aim_rods=("attack", "midfield"))
        run("lift, all slides +20 mm", back=False, lift=-1.4, slide=0.02)
