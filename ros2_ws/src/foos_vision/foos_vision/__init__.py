"""foos_vision: camera images (or a video file) in, the ball in the table frame out (`/ball/detection`,
`/ball/state`); also renders synthetic camera video of the simulated table, with known truth, to test it."""
