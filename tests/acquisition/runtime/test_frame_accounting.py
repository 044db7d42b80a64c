"""Every frame a camera delivers is accounted for, one of the wrong size included.

A simulated camera process writes a shared-memory ring at the configured size while the session
records; it then restarts at another size (a camera whose format was changed under the console),
and the camera driver, reconnecting, delivers frames the pipeline cannot measure. They are
counted as ``wrong_shape`` in the one accounting the status, the file and the replay share, and
the identity ``received = written + dropped + before + after + queued + wrong_shape`` holds.
"""

from __future__ import annotations

import time

from snrmon.acquisition.engine.status import FrameAccounting
from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.replay.batch import replay_session
from snrmon.acquisition.runtime.session import Session
from snrmon.sim.devices.shm_camera import RandomPattern, ShmProducer
from tests.helpers import H, SpotOnNoise, W, shm_camera_config, wait_until


def test_a_frame_of_the_wrong_size_is_counted_and_every_frame_is_accounted_for(tmp_path):
    ring = f"snrmon-shape-{time.monotonic_ns() % 10**9}"
    right = ShmProducer(ring, W, H, SpotOnNoise(5), fps=60.0, slots=16)
    right.start()
    session = Session(shm_camera_config(ring, camera="mwir"))
    wrong = None
    try:
        session.start()
        session.start_recording(tmp_path / "shape.h5")
        wait_until(lambda: session.status().cameras["mwir"].frames.written >= 30, 20.0, "frames")
        right.stop()
        wrong = ShmProducer(ring, W + 16, H, RandomPattern(W + 16, H, seed=1), fps=60.0, slots=16)
        wrong.start()
        wait_until(
            lambda: (session.status().cameras["mwir"].frames.wrong_shape or 0) >= 5,
            30.0,
            "frames of the wrong size",
        )
        live = session.status().cameras["mwir"].frames
        summary = session.stop_recording()
    finally:
        session.stop()
        right.stop()
        if wrong is not None:
            wrong.stop()

    assert live.wrong_shape >= 5 and live.written >= 30
    kept = FrameAccounting.from_record(summary.extra["accounting"]["mwir"])
    assert kept.wrong_shape is not None and kept.wrong_shape >= live.wrong_shape
    assert kept.received == (
        kept.written
        + sum(kept.dropped.values())
        + kept.before_recording
        + kept.after_recording
        + kept.queued
        + kept.wrong_shape
    )
    assert kept.unaccounted == 0 and kept.queued == 0
    with open_session(tmp_path / "shape.h5") as f:
        assert f.cameras["mwir"].n_frames == kept.written
    # the replay reads the same accounting back from the file
    assert replay_session(tmp_path / "shape.h5", fast=True).cameras["mwir"].accounting == kept
