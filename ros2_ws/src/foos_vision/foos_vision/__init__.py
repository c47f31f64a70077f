"""foos_vision: camera images (or a video file) in, the ball in the table frame out (`/ball/detection`,
`/ball/state`); also renders synthetic camera video of the simulated table, with known truth, to test it.

Modules, one concern each. The tracker (ROS-free), along a frame's path:

  markers, geometry      the markers file; tags to the ball-plane homography, the lens
  field_corners,         a table without tags: the field's corners given in pixels (parsed, checked),
  corner_refine          and fitted to the table's edges in the first frame
  field_view             the field as the camera sees it: tag fit, searched region, rods on their steel,
                         the figures at this frame's joints, the ball's expected radius
  figure_mask, rod_lines the figures' and the rods' image from the foos_sim model and the camera
  detector               colour models and ball-sized blobs (candidates) with sub-pixel centres
  candidate_rules        whether a blob is the ball: shape, figures over or joined to their rods, fixtures
  ball_search            the searches: near the track, elsewhere, the whole field, runs of partial balls,
                         and streaks
  streaks                a motion-blurred ball: the shares of its colour per pixel, a moving disc fitted
  motion_ball            the static table's background and the ball's shares where the table changed
  ball_colour            the `auto` colour vote, the colour learnt from what moves, and from the ball seen
  tracker                BallTracker: the track's state, frame by frame; choose_colour
  velocity, backfill     Kalman filter and central differences; the offline backward pass
  joint_sync             live frames paired with rod joint readings

Around it: bag_inputs (what the commands read from bags), image_msg (sensor_msgs/Image to BGR), video_io,
camera (camera configs and intrinsics), annotate; the commands track_cli, render_cli, calibrate_camera,
bench (with real_bench: real footage, and still_ball: the ball in a single still), and the nodes
tracker_node and video_source; the synthetic camera: scene, render, scenarios, hands,
boards, and shots (a bag of shots at 3-8 m/s to film).
"""
