"""The simulated camera: the table filmed from a camera over it, with its ground truth.

Below the tracker (foos_vision), since rendering the table is the simulator's job; the tracker's bench and
tests film with it, and sim_node publishes its images. One concern per module:

  scene       the model the camera films: the table's MJCF plus tags, lights, team colours, hands
  hands       a player's hand that reaches in and picks the ball up (posed per frame)
  render      frames from a camera config (pinhole or fisheye), blur, noise, exposure; the truth files
  scenarios   what is filmed: a simulated rollout, or states replayed from a bag
  recorded    the states a bag gives to film (render_video --bag)
  shots       a bag of shots past figures at 3-8 m/s, to film streaks
  boards      checkerboard views through a lens, for calibrate_camera's bench
  render_cli  `ros2 run foos_sim render_video`

The camera's description (foos_core.camera_model) and the tags' layout (foos_core.markers) sit in foos_core,
shared with the tracker.
"""
