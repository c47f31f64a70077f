"""foos_core: the table contract in code, below every other package of the workspace.

- `names`: teams, rods, joints, the command layout and the model's geom names (shared/CONTRACT.md);
- `table_params`: the one parameter file of the table (`params/regulation_table.yaml`), loaded,
  layered and validated, and `TableGeometry`, the dimensions other packages read from it;
- `joints`: putting a message's joints into the contract's order by name;
- `stamps`: ROS stamps to and from seconds;
- `node_signals` and `nodes.run_node`: how every node of the workspace starts and stops;
- `camera_model`, `markers`: a camera's description and the ArUco tags' layout, shared by the simulated
  camera (foos_sim.camera) and the tracker (foos_vision); `command_line`: how the image commands fail.

Only `node_signals` and `nodes` import rclpy; the rest is plain Python, numpy and OpenCV.
"""
