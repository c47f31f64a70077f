"""foos_sim: a MuJoCo model of a regulation foosball table in SI units, and its simulation API.

`load_model(params_file=None)` returns the nominal table, or the one a calibrated parameter file
describes. The ROS node lives in `foos_sim.sim_node`; nothing here imports ROS.
"""
from .model_builder import build_mjcf, load_model
from .table_params import DEFAULT_PARAMS_FILE, ParamsError, load_params

__all__ = ["load_model", "build_mjcf", "load_params", "DEFAULT_PARAMS_FILE", "ParamsError"]
