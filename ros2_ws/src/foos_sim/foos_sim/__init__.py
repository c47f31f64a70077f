"""foos_sim: a MuJoCo model of a regulation foosball table in SI units, and its simulation API.

`load_model(params_file=None)` returns the nominal table, or the one a calibrated parameter file
describes; `TableSimulation` steps it with the contract's joints, commands and goal rule;
`command_limits(params)` gives a controller the drives' limits without building a model. The parameter
file itself is read by foos_core.table_params. The ROS node lives in `foos_sim.sim_node`; nothing here
imports ROS.
"""
from .model_builder import build_mjcf, command_limits, load_model
from .simulation import TableSimulation

__all__ = ["load_model", "build_mjcf", "command_limits", "TableSimulation"]
