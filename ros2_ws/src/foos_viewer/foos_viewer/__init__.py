"""foos_viewer: the table as people watch it. `scene_node` serves a live Foxglove 3D scene (WebSocket) of the
table, the figures posed from /joint_states, the ball, its detections and the twin's prediction."""
