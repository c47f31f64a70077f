"""Calibration: what the nominal simulation gets wrong, why, and the fitted extension of the model.

ROS-free. `cli.main` is `ros2 run foos_sim calibrate BAG --out DIR`; `generate.main` is
`ros2 run foos_sim generate_measured`, the synthetic "measured data" generator with hidden effects.
"""
