"""drive_shaping's jerk-limited lanes kept between calls (blocks of lanes followed together) give each lane the same bits
as following it afresh, whichever blocks the lanes of a call come from."""
import numpy as np

from foos_calibration import drive_shaping

LIMIT = np.tile([3.48, 314.159], 4)  # the robot table's slide (m/s) and rotation (rad/s) command limits
ACCEL = np.tile([104.0, 9425.0], 4)
JERK = np.tile([406.0, 36650.0], 4)


def _lanes(rng, count):
    drives = rng.integers(0, 8, size=count)
    speed = LIMIT[drives] * rng.choice([0.3, 0.5, 1.0], size=count)
    accel = ACCEL[drives] * rng.choice([0.5, 1.0], size=count)
    delay = rng.choice([0.0, 0.006, 0.012], size=count)
    return drives, speed, accel, delay


def test_lanes_reused_across_blocks_have_the_bits_of_a_fresh_follow():
    rng = np.random.default_rng(3)
    events = 1500
    event_t = np.cumsum(rng.uniform(0.008, 0.012, events))
    commands = rng.choice([-1.0, -0.3, 0.0, 0.5, 1.0], size=(events, 8)) * LIMIT
    sample_t = np.arange(event_t[0] - 0.05, event_t[-1], 1 / 125)  # some samples before the first event
    drive_shaping.new_game()
    calls = []
    for call in range(8):
        lanes = _lanes(rng, 12)
        if call:  # half of each later call's lanes seen in earlier calls: rows from several blocks
            earlier = calls[rng.integers(len(calls))][0]
            lanes = tuple(np.concatenate([x[:6], y[:6]]) for x, y in zip(earlier, lanes))
        calls.append((lanes, call % 2 == 1))
    kept = []
    for (drives, speed, accel, delay), with_acceleration in calls:
        out = drive_shaping.shaped_velocity(event_t, commands[:, drives], sample_t, delay, speed, accel, np.full(len(drives), 0.001),
                                            JERK[drives], acceleration=with_acceleration)
        kept.append(out if with_acceleration else (out,))
    assert len(drive_shaping.RECURRENCES.blocks) > 2
    for ((drives, speed, accel, delay), with_acceleration), got in zip(calls, kept):
        drive_shaping.new_game()
        fresh = drive_shaping.shaped_velocity(event_t, commands[:, drives], sample_t, delay, speed, accel, np.full(len(drives), 0.001),
                                              JERK[drives], acceleration=with_acceleration)
        fresh = fresh if with_acceleration else (fresh,)
        for x, y in zip(got, fresh):
            assert x.shape == y.shape and np.array_equal(x.view(np.int64), y.view(np.int64))
