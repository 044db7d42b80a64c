"""The per-stage clock of a live frame: the attribution of time to stages (on a clock the test
drives, so every figure is known exactly), nesting, and its wiring in the camera pipeline."""

from __future__ import annotations

import os
import threading

import numpy as np
import pytest

from snrmon.acquisition import stage_clock
from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.engine.session_engine import SessionEngine
from snrmon.acquisition.runtime.camera_pipeline import CameraPipeline
from snrmon.acquisition.stage_clock import (
    COLUMNS,
    CORRECTION,
    EQ4,
    HANDOVER,
    RECORDING,
    STATISTICS,
    TRACKING,
    UNKNOWN,
    StageClock,
    enter,
)
from snrmon.acquisition.streams.ring import FrameRing, RingFrame
from snrmon.drivers.device import DeviceState, DeviceStatus


class _Ticks:
    """``time.monotonic_ns`` replaced by the times the test lists."""

    def __init__(self, times):
        self.times = list(times)

    def __call__(self) -> int:
        return self.times.pop(0)


def _column(rows: np.ndarray, name: str) -> list[int]:
    return rows[:, COLUMNS.index(name)].tolist()


def test_time_goes_to_the_stage_running_and_nested_stages_give_it_back(monkeypatch):
    clock = StageClock(frames=8)
    us = 1000
    # (us) popped at 10; recording 11-13; tracking 13-15; Eq. 4 inside it 15-17, which reads
    # a lazily corrected pixel 17-20, then Eq. 4 again 20-21; tracking 21-30; statistics
    # 30-35; handover 35-40.
    ticks = _Ticks([t * us for t in (10, 11, 13, 15, 17, 20, 21, 30, 35, 40)])
    monkeypatch.setattr(stage_clock.time, "monotonic_ns", ticks)
    clock.begin(t_host_ns=0, t_ring_ns=4 * us, grab_ns=3 * us)
    clock.enter(RECORDING)
    clock.enter(TRACKING)
    running = clock.enter(EQ4)
    assert running == TRACKING
    inside = clock.enter(CORRECTION)
    assert inside == EQ4
    clock.enter(inside)
    clock.enter(running)
    clock.enter(STATISTICS)
    clock.enter(HANDOVER)
    assert clock.end() == 40 * us
    rows = clock.rows()
    assert rows.shape == (1, len(COLUMNS))
    want = {
        "grab": 3,
        "ring": 10,
        "recording": 2,
        "tracking": 11,
        "eq4": 3,
        "correction": 3,
        "statistics": 5,
        "handover": 5,
        "latency": 40,
    }
    for name, value in want.items():
        assert _column(rows, name) == [value * us], name
    # No scheduler statistics without attach(): the split of the wait is unknown, not 0.
    assert _column(rows, "cpu") == _column(rows, "runq") == _column(rows, "blocked") == [UNKNOWN]
    summary = clock.summary()
    assert summary["frames"] == 1
    assert summary["eq4"] == {"p50_ms": 0.003, "p99_ms": 0.003, "slowest_ms": 0.003}
    assert summary["cpu"] == {"p50_ms": None, "p99_ms": None, "slowest_ms": None}


def test_a_frame_that_waited_for_the_previous_one_counts_it_as_backlog(monkeypatch):
    clock = StageClock(frames=4)
    # frame 1: pushed at 5, popped at 6, done at 50; frame 2 pushed at 20 (while frame 1 was
    # measured), popped at 51, done at 60: 30 ns of backlog.
    monkeypatch.setattr(stage_clock.time, "monotonic_ns", _Ticks([6, 50, 51, 60]))
    clock.begin(t_host_ns=1, t_ring_ns=5)
    clock.end()
    clock.begin(t_host_ns=18, t_ring_ns=20)
    clock.end()
    rows = clock.rows()
    assert _column(rows, "backlog") == [0, 30]
    assert _column(rows, "ring") == [5, 33]
    assert _column(rows, "push") == [4, 2]
    assert _column(rows, "grab") == [UNKNOWN, UNKNOWN]


def test_the_window_keeps_the_last_frames_oldest_first_and_reset_forgets(monkeypatch):
    clock = StageClock(frames=3)
    times = []
    for k in range(5):
        times += [100 * k + 1, 100 * k + 1 + k]  # frame k takes k ns after its pop
    monkeypatch.setattr(stage_clock.time, "monotonic_ns", _Ticks(times))
    for k in range(5):
        clock.begin(t_host_ns=100 * k, t_ring_ns=100 * k)
        clock.end()
    assert clock.frames == 5
    assert _column(clock.rows(), "latency") == [3, 4, 5]
    clock.reset()
    assert clock.frames == 0 and clock.summary() == {"frames": 0}


def test_enter_does_nothing_on_a_thread_without_a_clock():
    out = []
    t = threading.Thread(target=lambda: out.append(enter(EQ4)))
    t.start()
    t.join()
    assert out == [-1]


def _pipeline() -> CameraPipeline:
    h, w = 48, 64
    config = session_config_from_dict(
        {"cameras": {"cam": {"source": "shm", "address": "none", "width_px": w, "height_px": h}}}
    )

    class NoDevice:  # the frames come by hand: a device that delivers none and lost none
        def subscribe(self, cb):
            return lambda: None

        def status(self) -> DeviceStatus:
            return DeviceStatus(name="cam", state=DeviceState.STREAMING)

    return CameraPipeline("cam", NoDevice(), SessionEngine(config, {"cam": (h, w)}))


def test_the_pipeline_times_every_frame_it_measures_on_its_thread():
    pipe = _pipeline()
    rng = np.random.default_rng(5)
    yy, xx = np.mgrid[0:48, 0:64]
    spot = 200.0 * np.exp(-((xx - 30) ** 2 + (yy - 20) ** 2) / 1.3)
    pipe.set_roi(30, 20)

    def measure() -> None:  # as the pipeline's measurement thread does
        pipe.stages.attach()
        try:
            for i in range(40):
                pixels = np.rint(1000 + spot + rng.normal(0, 5, (48, 64))).astype(np.uint16)
                t = stage_clock.time.monotonic_ns()
                pipe._process(RingFrame(pixels, i, i, t, None, "cam", t))
        finally:
            pipe.stages.detach()

    t = threading.Thread(target=measure)
    t.start()
    t.join()
    summary = pipe.stage_times()
    assert summary["frames"] == 40
    measured = ["ring", "tracking", "eq4", "statistics", "handover", "latency"]
    if os.path.exists("/proc/thread-self/schedstat"):  # Linux: the thread's CPU time
        measured.append("cpu")
    for name in measured:
        assert summary[name]["p99_ms"] is not None and summary[name]["p99_ms"] >= 0, name
    assert summary["grab"]["p50_ms"] is None  # no camera write time: not measured
    rows = pipe.stages.rows()
    stages = [COLUMNS.index(s) for s in stage_clock.STAGES[1:]]
    # The stages of a frame add up to (at most) its latency: nothing is counted twice.
    assert (rows[:, stages].sum(axis=1) <= rows[:, COLUMNS.index("latency")]).all()
    assert (rows[:, COLUMNS.index("eq4")] > 0).all()  # every frame measured Eq. (4)


@pytest.mark.parametrize("capacity", [2, 7])
def test_the_ring_stamps_when_it_published_a_frame(capacity):
    from snrmon.drivers.camera.frame import Frame

    ring = FrameRing(capacity, 2, 3)
    reader = ring.reader("r")
    before = stage_clock.time.monotonic_ns()
    ring.push(Frame(np.zeros((2, 3), np.uint16), "c", 1, 5, None))
    after = stage_clock.time.monotonic_ns()
    item = reader.pop_next(timeout=0)
    assert item is not None and before <= item.t_ring_ns <= after
    assert item.t_host_ns == 5
