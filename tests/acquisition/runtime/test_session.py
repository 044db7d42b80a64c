"""The Session end to end on simulated devices through their real interfaces.

A camera process writes a shared-memory frame ring (a drifting Gaussian spot on noise), an LDM
rangefinder and an NMEA GPS speak on pseudo-terminals; the Session opens them by name and path
as it would open real devices, measures every frame, detects the stop from the steady range,
and records a session file that reads back with plain h5py semantics.
"""

from __future__ import annotations

import json
import math
import time

import numpy as np
import pytest
from threadpoolctl import threadpool_info

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.replay.batch import replay_session
from snrmon.acquisition.runtime.session import Session
from snrmon.acquisition.stops.detector import StopConfig
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.helpers import (
    AMPLITUDE_DN,
    NOISE_DN,
    H,
    SpotOnNoise,
    W,
    field_devices,
    field_session_config,
    running_n,
    wait_until,
)


@pytest.fixture
def rig(tmp_path):
    name = f"snrmon-test-{time.monotonic_ns() % 10**9}"
    with field_devices(name, seed=7, range_m=150.0, lrf_hz=20.0) as (producer, lrf, gps):
        config = field_session_config(name, lrf, gps)
        session = Session(config, stop_config=StopConfig(steady_s=1.0, min_readings=3))
        try:
            yield session, producer, tmp_path
        finally:
            session.stop()


def test_session_measures_every_frame_detects_the_stop_and_records(rig):
    session, producer, tmp_path = rig
    session.start()
    # the live settings (acquisition/runtime/interpreter.py): BLAS on one thread while it runs
    assert {p["num_threads"] for p in threadpool_info() if p["user_api"] == "blas"} == {1}
    session.set_roi("cam", 66, 39)  # a click within the search window of the spot
    # The click takes effect before the next frame: wait until the engine has measured with it,
    # so that the recording begins after the click (the first recorded state holds the track).
    wait_until(lambda: session.status().cameras["cam"].roi_xy is not None, 10.0, "the click")
    path = tmp_path / "session.h5"
    session.start_recording(path)
    wait_until(lambda: any(r.reading.complete for r in session.stops()), 20.0, "a complete stop")
    # Replay rebuilds the stop from the recorded range stream alone, which starts when the
    # recording does, a little after the live detector's first reading: record one more second
    # so that the replayed stop also has its 100 frames.
    measured = session.pipelines["cam"].stages.frames  # frames the measurement is done with
    wait_until(lambda: session.pipelines["cam"].stages.frames >= measured + 60, 10.0, "1 s more")
    summary = session.stop_recording()
    st = session.status()
    cam = st.cameras["cam"]

    # The peak is the spot's pixel and the SNR is the spot's amplitude over the noise.
    assert (cam.last.result.peak_x, cam.last.result.peak_y) == (64, 41)
    row = next(r for r in session.stops() if r.reading.complete)
    assert row.reading.n_frames == 100
    assert row.place.lrf_range_m == pytest.approx(150.0, abs=0.01)
    expected = (AMPLITUDE_DN * math.exp(-(0.3**2 + 0.4**2) / (2 * 0.7**2))) / NOISE_DN
    assert row.reading.snr_mean == pytest.approx(expected * 1.034, rel=0.08)
    # GPS slant range from the site: 1250-1200 m up, ~150 m horizontally.
    assert st.gps_range_m == pytest.approx(math.hypot(50.0, 147.8), rel=0.02)

    # Every frame is accounted for: after the stop the measurement thread has drained the ring,
    # so every frame received was measured (with no recording now: before_recording) or lost to
    # the ring; the recorder wrote what it was given. The camera's own gaps are none unless the
    # machine held the simulated camera back past its buffer, and never more than it skipped
    # (it goes on after the session stops: a last gap may be one the session never saw).
    session.stop()
    acc = session.status().cameras["cam"].frames
    assert acc.camera_gap <= producer.frames_skipped
    assert acc.dropped == {"ring_overrun": 0} and acc.queued == 0
    assert acc.received == acc.before_recording > 0 and acc.unaccounted == 0
    assert summary.frames_received["cam"] == summary.frames_written["cam"] + sum(
        summary.dropped["cam"].values()
    )

    # The recording holds the frames, the per-frame measurements, the raw streams and the ROI.
    f = open_session(path)
    frames = f.cameras["cam"]
    n = summary.frames_written["cam"]
    assert n > 0 and frames.frames.shape == (n, H, W)
    assert np.all(np.diff(frames.t_host_ns[:]) > 0)
    meas = frames.measurements[:]
    assert np.all(meas["peak_x"][meas["frame_index"] >= 0] == 64)
    assert len(f.rangefinder) > 0 and len(f.gps) > 0
    # The click came before the recording: the engine's state at the first recorded frame
    # holds the track (where the search window was), and a replay starts from it.
    first_state = json.loads(bytes(frames.states[0]["state"]).decode())
    assert frames.states[0]["counter"] == frames.counter[0]
    assert tuple(first_state["measurer"]["roi"]) in {(64, 41), (66, 39)}
    # The live stop table is part of the record: the completed row, as the console showed it.
    (summary_event,) = [e for e in f.event_list() if e["kind"] == "stop_summary"]
    assert summary_event["payload"]["n_frames"] == 100
    assert summary_event["payload"]["snr_mean"] == row.reading.snr_mean
    f.close()

    # Replay through the same measurement reproduces every recorded per-frame SNR exactly,
    # and rebuilds the stop from the recorded range stream.
    replay = replay_session(path)
    cam_replay = replay.cameras["cam"]
    assert cam_replay.compared >= 100
    assert cam_replay.identical == cam_replay.compared
    assert any(
        r.reading.complete and r.place.lrf_range_m == pytest.approx(150.0, abs=0.01)
        for r in replay.stops
    )
    # --fast reads only the square around the track: the same numbers, frame for frame.
    fast = replay_session(path, fast=True)
    assert fast.cameras["cam"].compared == cam_replay.compared
    assert fast.cameras["cam"].identical == cam_replay.compared
    assert fast.stops == replay.stops


def test_background_reference_removes_fixed_pattern_and_replays_exactly(tmp_path):
    name = f"snrmon-fpn-{time.monotonic_ns() % 10**9}"
    producer = ShmProducer(
        name, W, H, SpotOnNoise(11, fpn_dn=15.0, spot_from=10**9), fps=60.0, slots=16
    )
    producer.start()
    config = session_config_from_dict(
        {"cameras": {"cam": {"source": "shm", "address": name, "width_px": W, "height_px": H}}}
    )
    session = Session(config, track=False)
    path = tmp_path / "fpn.h5"
    try:
        session.start()
        session.start_recording(path)
        session.capture_reference("cam", 32)
        wait_until(
            lambda: session.status().cameras["cam"].figures.reference_frames == 32, 10, "reference"
        )
        session.set_roi("cam", 64, 41)
        wait_until(lambda: running_n(session.status(), "cam") >= 60, 10, "60 measured frames")
        session.stop_recording()
        st = session.status().cameras["cam"]
    finally:
        session.stop()
        producer.stop()
    # The reference holds the 15 DN pattern (plus the temporal noise averaged over 32 frames).
    assert st.figures.fixed_pattern_dn == pytest.approx(
        math.hypot(15.0, NOISE_DN / math.sqrt(32)), rel=0.1
    )
    # No spot in these frames: the corrected rim std is the temporal noise (x sqrt(1 + 1/32)
    # for the noise left in the reference), the raw one carries the pattern.
    assert st.last.result.bg_std == pytest.approx(NOISE_DN * math.sqrt(1 + 1 / 32), rel=0.35)
    for fast in (False, True):  # --fast applies the reference to its square only
        replay = replay_session(path, fast=fast).cameras["cam"]
        assert replay.compared >= 60 and replay.identical == replay.compared, fast


def test_camera_lost_raises_an_alarm_and_clears_when_it_returns(rig):
    session, producer, _ = rig
    session.pipelines["cam"].device.stale_after_s = 0.3
    session.start()
    wait_until(lambda: session.status().cameras["cam"].frames.received > 10, 10.0, "frames")
    producer.pause()
    wait_until(lambda: any("cam" in a for a in session.status().alarms), 5.0, "the alarm")
    producer.resume()
    wait_until(lambda: not any("cam" in a for a in session.status().alarms), 5.0, "no alarm")


def test_roi_off_the_image_is_refused(rig):
    session, _, _ = rig
    with pytest.raises(ValueError, match="outside the cam image"):
        session.set_roi("cam", W + 5, 10)
    with pytest.raises(ValueError, match="no camera 'x'"):
        session.set_roi("x", 1, 1)
