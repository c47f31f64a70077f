"""tracker_node's pairing of frames with rod joint readings (foos_vision.joint_sync), without ROS: a frame
waits for the reading of its own time, within bounds, and frames always leave in order."""
from __future__ import annotations

import numpy as np

from foos_vision.joint_sync import JointSync


def q(value: float) -> np.ndarray:
    return np.full(16, value)


def stamps(ready) -> list[float]:
    return [r.stamp for r in ready]


def test_a_table_without_encoders_never_waits():
    sync = JointSync()
    ready = sync.add_frame(1.0, "a", wall=0.0)
    assert stamps(ready) == [1.0] and ready[0].joints is None and ready[0].payload == "a"


def test_a_frame_ahead_of_the_readings_waits_for_its_own_and_is_interpolated():
    sync = JointSync()
    assert sync.add_joints(0.98, q(0.0)) == []
    assert sync.add_frame(1.0, "f1", wall=0.0) == []  # its reading is not there yet
    assert sync.add_frame(1.01, "f2", wall=0.0) == []
    ready = sync.add_joints(1.005, q(1.0))  # covers f1, not f2
    assert stamps(ready) == [1.0]
    assert np.allclose(ready[0].joints, 0.8)  # 1.0 lies 80 % of the way from 0.98 to 1.005
    ready = sync.add_joints(1.02, q(2.0))
    assert stamps(ready) == [1.01] and np.allclose(ready[0].joints, 1.0 + (1.01 - 1.005) / 0.015)
    assert sync.unmatched == 0


def test_a_lagging_joint_queue_does_not_leave_frames_with_a_stale_pose():
    """The failure seen under load: images dropped, the joint queue taken one reading per turn, so the
    readings in hand lag the frames by several frame times; each frame must get its own time's pose."""
    sync = JointSync()
    fps = 120.0
    for k in range(5):
        sync.add_joints(k / fps, q(k))
    ready = []
    for k in range(5, 40):
        ready += sync.add_frame(k / fps, k, wall=0.0)  # frame k arrives before reading k
        ready += sync.add_joints((k - 3) / fps, q(k - 3))
    ready += sync.add_joints(40 / fps, q(40))
    assert stamps(ready) == [k / fps for k in range(5, 40)]
    for r in ready:
        assert np.allclose(r.joints, r.payload)


def test_waiting_is_bounded_by_frame_stamps_and_by_wall_time():
    sync = JointSync(max_hold=0.1, max_wait_wall=0.25)
    sync.add_joints(0.0, q(0.0))
    assert sync.add_frame(0.05, "a", wall=10.0) == []
    assert sync.add_frame(0.12, "b", wall=10.1) == []
    ready = sync.add_frame(0.16, "c", wall=10.2)  # a is now more than 0.1 s of stamps behind the newest
    assert [r.payload for r in ready] == ["a"] and np.allclose(ready[0].joints, 0.0)
    assert sync.due(wall=10.3) == []
    ready = sync.due(wall=10.36)  # b has waited more than 0.25 s of wall time
    assert [r.payload for r in ready] == ["b"]
    assert ready[0].joints is None  # over 0.1 s after the last reading: nothing says where the figures are
    assert [r.payload for r in sync.flush()] == ["c"]
    assert sync.unmatched == 3


def test_readings_that_stopped_do_not_delay_frames_and_a_replay_starts_over():
    sync = JointSync()
    sync.add_joints(1.0, q(1.0))
    assert stamps(sync.add_frame(5.0, "late", wall=0.0)) == [5.0]  # encoders gone for 4 s
    sync.add_joints(0.5, q(0.5))  # a bag played again: the history starts over
    assert sync.latest_stamp == 0.5
    ready = sync.add_frame(0.5, "replayed", wall=0.0)
    assert stamps(ready) == [0.5] and np.allclose(ready[0].joints, 0.5)
