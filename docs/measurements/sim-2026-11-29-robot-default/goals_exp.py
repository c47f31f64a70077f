"""Goals a minute of the game generator's players: servo table, robot table with the players' cap (now), robot table
at the drives' full speeds (before): 60 s games, seeds 1-5, default options.
Run from the repository root in a shell that sourced scripts/env.sh."""
from foos_calibration import games
from foos_calibration.games import GameOptions
from foos_core.table_params import SERVO_PARAMS_FILE, load_params

rows = []
for case in ("servo", "robot capped", "robot full speed"):
    if case == "robot full speed":
        games.PLAYER_SPEED_LIMITS = (1e9, 1e9)
    params = load_params(SERVO_PARAMS_FILE) if case == "servo" else None
    for seed in range(1, 6):
        rec = games.play([], GameOptions(duration=60.0, seed=seed), params=params)
        print(case, seed, "serves", rec.serves, "goals", len(rec.goals), "touches", rec.touches, flush=True)
