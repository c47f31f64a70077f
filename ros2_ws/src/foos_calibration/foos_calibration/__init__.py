"""foos_calibration: what the nominal simulation gets wrong, why, and the fitted extension of the model.

Bag in (`/ball/detection`), report and calibrated parameter file out. ROS-free. `cli.main` is
`ros2 run foos_calibration calibrate BAG --out DIR`; `generate.main` is
`ros2 run foos_calibration generate_measured`, the synthetic "measured data" generator with hidden effects.
"""
