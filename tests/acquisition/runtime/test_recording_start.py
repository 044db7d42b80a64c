"""A recording started while a frame is being measured: the stop table's history the recording
begins with holds exactly the frames measured before its first recorded frame, so the replay's
stop rows equal the live ones (a frame measured across the start was once in neither the history
nor the file, and the replayed row took the next frame in its place)."""

from __future__ import annotations

import threading
import time

import pytest

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.replay.batch import replay_session
from snrmon.acquisition.runtime.session import Session
from snrmon.acquisition.stops.detector import StopConfig
from snrmon.acquisition.stops.table import row_values_equal
from snrmon.sim.devices.ldm_sim import LdmSimulator
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.helpers import H, SpotOnNoise, W, running_n, wait_until


class HeldFrame:
    """Holds one frame inside its measurement (after the pipeline looked at the recorder, before
    the stop table has it) until the test lets it go."""

    def __init__(self) -> None:
        self.armed = threading.Event()
        self.entered = threading.Event()
        self.release = threading.Event()

    def wrap(self, process):
        held = self

        def hold(engine: CameraEngine, *args, **kwargs):
            if held.armed.is_set() and not held.entered.is_set():
                held.entered.set()
                assert held.release.wait(20.0), "the test never released the held frame"
            return process(engine, *args, **kwargs)

        return hold


@pytest.fixture
def held(monkeypatch):
    h = HeldFrame()
    monkeypatch.setattr(CameraEngine, "process", h.wrap(CameraEngine.process))
    return h


@pytest.fixture
def session(tmp_path, held):
    name = f"snrmon-start-{time.monotonic_ns() % 10**9}"
    producer = ShmProducer(name, W, H, SpotOnNoise(11), fps=60.0, slots=32)
    producer.start()
    lrf = LdmSimulator(lambda t: 150.0, rate_hz=20.0, tracking=True).start()
    config = session_config_from_dict(
        {
            "cameras": {"cam": {"source": "shm", "address": name, "width_px": W, "height_px": H}},
            "lrf": {"protocol": "ldm", "port": lrf.path, "baud": 9600},
        }
    )
    s = Session(config, stop_config=StopConfig(steady_s=1.0, min_readings=3))
    try:
        yield s
    finally:
        s.stop()
        producer.stop()
        lrf.stop()


def test_a_frame_measured_across_the_recording_start_is_in_the_replayed_row(
    session, held, tmp_path
):
    session.start()
    session.set_roi("cam", 66, 39)
    wait_until(lambda: bool(session.stops()), 20.0, "a stop")
    wait_until(lambda: running_n(session.status(), "cam") >= 5, 10.0, "a few measured frames")
    held.armed.set()  # the next frame is held inside its measurement
    assert held.entered.wait(10.0), "no frame came to be held"
    path = tmp_path / "start.h5"
    session.start_recording(path)  # while that frame is being measured
    held.release.set()
    measured = session.pipelines["cam"].stages.frames
    wait_until(
        lambda: session.pipelines["cam"].stages.frames >= measured + 120,
        10.0,
        "two more seconds",
    )
    session.stop()
    live_rows = session.stops()
    (row,) = live_rows
    assert row.reading.complete and row.final
    # The held frame is among the row's frames (the stop began before it).
    replay = replay_session(path, fast=True)
    t = replay.cameras["cam"].tally
    assert t.identical == t.compared > 0
    assert t.before_recording >= 5  # the history the recording began with
    assert len(replay.stops) == 1
    assert row_values_equal(replay.stops[0], row), (replay.stops[0], row)
    assert replay.stops_identical == 1
