"""The figure-restitution fit on the default (robot) drives, test_figure_bounces' three games, with the replays' drives
as measured (now) or at the table's own limits (before): clean replays, fitted, named."""
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[3]))  # the repository root, for tests/
from foos_calibration import figure_bounces
from foos_core.table_params import load_params
from tests.foos_calibration.test_figure_bounces import restitution_of_game

nominal = load_params()
for mode in ("as measured", "table's own"):
    if mode == "table's own":
        figure_bounces._driven_as_measured = lambda tree: tree
    for hidden, seed in ((0.75, 1), (0.3, 3), (0.5, 6)):
        f = restitution_of_game(nominal, hidden, seed=seed, duration=120.0)
        b = f.block
        print(mode, "hidden", hidden, "seed", seed, "slow", b.get("slow_figure_bounces"), "clean", b.get("clean_replays"),
              "fitted", round(f.fitted, 3), "named", f.coefficient is not None, b.get("reason", ""), flush=True)
