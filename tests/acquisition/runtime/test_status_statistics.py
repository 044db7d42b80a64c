"""The statistics a camera's status carries are taken on its measurement thread, never on the
thread that asks for the status (a console's, five times a second).

A simulated camera process writes a shared-memory ring at 60 frames/s; the session measures a
spot in it. Every call of the engine's ``statistics`` is recorded with the thread it ran on.
"""

from __future__ import annotations

import threading
import time

import numpy as np

from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.runtime.measurement_thread import STATISTICS_EVERY_S, MeasurementThread
from snrmon.acquisition.runtime.session import Session
from snrmon.acquisition.stage_clock import StageClock
from snrmon.acquisition.streams.ring import FrameRing, OverflowPolicy
from snrmon.drivers.camera.frame import Frame
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.helpers import H, SpotOnNoise, W, shm_camera_config, wait_until


def test_the_thread_takes_the_statistics_apart_and_once_more_when_frames_pause():
    ring = FrameRing(64, 4, 4, name="cam", policy=OverflowPolicy.WAIT)
    reader = ring.reader("measurement")
    processed: list[int] = []
    taken: list[tuple[str, int]] = []

    def statistics() -> int:
        taken.append((threading.current_thread().name, len(processed)))
        return len(processed)

    thread = MeasurementThread(
        "cam",
        reader,
        lambda frame: processed.append(frame.counter),
        lambda: None,
        StageClock(),
        statistics=statistics,
    )
    assert thread.statistics is None  # nothing measured, nothing taken
    thread.start()
    t0 = time.monotonic()
    try:
        for counter in range(40):
            ring.push(
                Frame(np.full((4, 4), counter, np.uint16), "cam", counter, time.monotonic_ns())
            )
        # the pause after the last frame: the statistics of all 40
        wait_until(lambda: thread.statistics == 40, 10.0, "the statistics of every frame")
    finally:
        thread.stop()
    elapsed_s = time.monotonic() - t0
    assert processed == list(range(40))
    assert {name for name, _ in taken} == {"measure-cam"}
    # never one per frame: at most one each STATISTICS_EVERY_S and the pause's (and the end's)
    assert len(taken) <= elapsed_s / STATISTICS_EVERY_S + 2
    assert taken[-1][1] == 40


def test_a_status_asked_on_another_thread_computes_no_statistics(monkeypatch):
    calls: list[str] = []
    original = CameraEngine.statistics

    def recorded(self):
        calls.append(threading.current_thread().name)
        return original(self)

    monkeypatch.setattr(CameraEngine, "statistics", recorded)
    ring = f"snrmon-stats-{time.monotonic_ns() % 10**9}"
    producer = ShmProducer(ring, W, H, SpotOnNoise(5), fps=60.0, slots=16)
    producer.start()
    session = Session(shm_camera_config(ring, camera="mwir"))
    try:
        session.start()
        session.set_roi("mwir", W // 2, H // 2)
        wait_until(
            lambda: session.pipelines["mwir"].measuring.statistics is not None,
            20.0,
            "the first statistics",
        )
        calls.clear()
        statuses = [session.status().cameras["mwir"] for _ in range(20)]
    finally:
        session.stop()
        producer.stop()
    assert "MainThread" not in calls  # the twenty statuses took theirs from the thread
    assert statuses[-1].frames.received > 0
    assert np.isfinite(statuses[-1].latency.p50_ms)  # the latency came with them
