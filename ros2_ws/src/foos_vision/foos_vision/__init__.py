"""foos_vision: camera images (or a video file) in, the ball in the table frame out (`/ball/detection`,
`/ball/state`). The simulated camera that films the table with known truth, to test it, is foos_sim.camera.

Modules, one concern each, in stages along a frame's path: a subpackage per stage, the shells at the top. A module
imports only its own stage, the stages above it in this list, and errors (the package's exceptions); no circle
of imports, counting those inside functions (tests/workspace/test_layering.py checks both).

camera/: the lens, tags or corners, then the mapping
  field_corners          a table without tags: the field's corners given in pixels (parsed, checked)
  geometry               tags (foos_core.markers) to the ball-plane homography, the lens
  figure_mask, rod_lines the figures' and the rods' image from the foos_sim model and the camera
  corner_refine          the field's corners fitted to the table's edges in the first frame
  field_lines, field_walls, field_auto
                         `--field-corners auto`: the field's corners found from the felt and the walls
  field_view             the field as the camera sees it: tag fit, searched region, rods on their steel,
                         the figures at this frame's joints, the ball's expected radius; the tag fits' counts
detection/: the candidates in one frame
  streaks                a motion-blurred ball: the shares of its colour per pixel, a moving disc fitted
  detector               colour models and ball-sized blobs (candidates) with sub-pixel centres
  motion_ball            the static table's background and the ball's shares where the table changed
  candidate_rules        whether a blob is the ball: shape, figures over or joined to their rods, fixtures
  ball_colour            the `auto` colour vote, the colour learnt from what moves, and from the ball seen
  ball_search            the searches: near the track (a SearchWindow: where and how sure, which tracking fills
                         in), elsewhere, the whole field, runs of partial balls, and streaks
  still_ball             the ball in a single still, nothing else known (real_bench's stills)
tracking/: association, Kalman, backfill
  velocity               Kalman filter and central differences
  tracker                BallTracker: the track's state, frame by frame; choose_colour
  backfill               the offline backward pass

The shells, at the top: bag_inputs (the joint states track_video reads from a bag), image_msg (sensor_msgs/Image
to BGR), joint_sync (tracker_node's live frames paired with rod joint readings), video_io, annotate; the commands
track_cli, calibrate_camera, bench (which films with foos_sim.camera; with real_bench: real footage, and
field_bench: `--field-corners auto` against the truth, and throughput: frames/s on one core), camera_loop (the
simulated camera in the loop, measured) and moved (render_video, now foos_sim's); the nodes tracker_node and video_source.
"""
