"""`python -m foos_policy.report EVAL.json ... [--runs DIR ...]`: the results table in Markdown.

Each evaluation JSON (from `evaluate`) is one row; rows of the same algorithm, reset and opponent that
differ only by seed (names like sac_hardened_scripted_s0, _s1, ...) are also summarised together: the
mean win rate over seeds with a Student-t 95 % interval (seed-to-seed spread), and the pooled episodes'
Wilson interval. --runs adds each training run's budget (steps done, wall time) from its run.json.
"""
from __future__ import annotations

import argparse
import json
import re
import sys
from collections import defaultdict
from pathlib import Path

from .evaluation import t_interval, wilson_interval

POLICY_COLUMNS = ("policy", "reset / opponent", "training budget", "episodes", "win rate [95 % CI]", "own-goal rate",
                  "mean length (steps)", "touches / episode", "goals after touch", "no-touch share of goals")
SEEDS_COLUMNS = ("algorithm (all seeds)", "reset / opponent", "seeds", "win rate mean over seeds [t 95 % CI]",
                 "pooled win rate [Wilson 95 % CI]", "pooled own-goal rate", "touches / episode")


def _header(columns: tuple[str, ...]) -> list[str]:
    """A Markdown table's header row and its separator."""
    return ["| " + " | ".join(columns) + " |", "|---" * len(columns) + "|"]


def _ci(pair) -> str:
    return "n/a" if not pair else f"[{pair[0]:.2f}, {pair[1]:.2f}]"


def _share(s: dict) -> str:
    share = s.get("no_touch_goal_share")
    return "n/a (no goals)" if share is None else f"{share:.2f} {_ci(s.get('no_touch_goal_share_ci95'))}"


def load_runs(dirs: list[str]) -> dict[str, dict]:
    runs = {}
    for d in dirs:
        for path in [*Path(d).glob("**/run.json"), *Path(d).glob("**/*.run.json")]:
            run = json.loads(path.read_text())
            runs[run["name"]] = run
    return runs


def table(evals: list[dict], runs: dict[str, dict]) -> str:
    lines = _header(POLICY_COLUMNS)
    groups: dict[tuple, list[dict]] = defaultdict(list)
    for s in evals:
        name = Path(str(s["policy"])).stem
        run = runs.get(name)
        budget = "-" if run is None else f"{run['steps_done']:,} steps ({run['wall_s'] / 60:.0f} min)"
        lines.append(
            f"| {name} | {s['reset']} / {s['opponent']} | {budget} | {s['episodes']} | {s['win_rate']:.2f} {_ci(s['win_rate_ci95'])} "
            f"| {s['own_goal_rate']:.2f} | {s['mean_length']:.0f} | {s['touches']:.1f} | {s['goals_after_touch']:.2f} | {_share(s)} |")
        m = re.match(r"(.+)_s\d+$", name)
        if m:
            groups[(m.group(1), s["reset"], s["opponent"])].append(s)
    out = ["\n".join(lines)]
    multi = {k: v for k, v in groups.items() if len(v) >= 2}
    if multi:
        out.append("")
        out.extend(_header(SEEDS_COLUMNS))
        for (stem, reset, opponent), rows in sorted(multi.items()):
            rates = [r["win_rate"] for r in rows]
            mean, lo, hi = t_interval(rates)
            n = sum(r["episodes"] for r in rows)
            wins = sum(r["win_rate"] * r["episodes"] for r in rows)
            losses = sum(r["own_goal_rate"] * r["episodes"] for r in rows)
            touches = sum(r["touches"] * r["episodes"] for r in rows) / n
            pooled = wilson_interval(round(wins), n)
            out.append(f"| {stem} | {reset} / {opponent} | {len(rows)} | {mean:.2f} [{max(lo, 0):.2f}, {min(hi, 1):.2f}] "
                       f"| {wins / n:.2f} {_ci(pooled)} | {losses / n:.2f} | {touches:.1f} |")
    return "\n".join(out)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(prog="report", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("evals", nargs="+", help="evaluation JSON files from `evaluate`")
    p.add_argument("--runs", nargs="*", default=[], help="training output directories (their run.json give the budgets)")
    args = p.parse_args(argv)
    try:
        evals = [json.loads(Path(f).read_text()) for f in args.evals]
    except (OSError, json.JSONDecodeError) as exc:
        print(f"report: {exc}".splitlines()[0], file=sys.stderr)
        return 1
    print(table(evals, load_runs(args.runs)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
