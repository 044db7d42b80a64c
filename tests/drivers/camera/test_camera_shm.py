"""Shared-memory frame ring: simulated camera process (sim) -> ShmCamera (drivers) through a real
POSIX shared-memory object, as in docs/shm-frame-ring.md."""

from __future__ import annotations

import itertools
import os
import queue
import threading
import time
import uuid
from collections.abc import Callable

import numpy as np
import pytest

from snrmon.drivers.camera.format import CameraFormat
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.camera.shm import ShmCamera
from snrmon.drivers.device import DeviceState, DeviceStatus
from snrmon.sim.devices.shm_camera import (
    RandomPattern,
    ShmFrameWriter,
    ShmProducer,
    StampPattern,
    unlink_ring,
)

W, H = 64, 48


class Watch:
    """Collects a camera's frames and status changes; waits on a condition, never sleeps."""

    def __init__(self, cam: ShmCamera) -> None:
        self.cam = cam
        self.frames: list[Frame] = []
        self.states: list[DeviceState] = []
        self.errors: list[str] = []
        self._cv = threading.Condition()
        cam.subscribe(self._frame)
        cam.subscribe_status(self._status)

    def _frame(self, frame: Frame) -> None:
        with self._cv:
            self.frames.append(frame)
            self._cv.notify_all()

    def _status(self, st: DeviceStatus) -> None:
        with self._cv:
            if not self.states or self.states[-1] != st.state:
                self.states.append(st.state)
            if st.last_error and (not self.errors or self.errors[-1] != st.last_error):
                self.errors.append(st.last_error)
            self._cv.notify_all()

    def until(self, what: str, pred: Callable[[], bool], timeout_s: float = 10.0) -> None:
        """Wait for ``pred``: woken by every frame and status change, and re-checked every
        20 ms for conditions no callback announces (the format is set on attach)."""
        deadline = time.monotonic() + timeout_s
        with self._cv:
            while not pred():
                left = deadline - time.monotonic()
                if left <= 0:
                    pytest.fail(f"timed out waiting for {what}; status {self.cam.status()}")
                self._cv.wait(min(left, 0.02))


@pytest.fixture
def ring_name():
    name = f"snrmt_{os.getpid()}_{uuid.uuid4().hex[:8]}"
    yield name
    unlink_ring(name)


def test_frames_round_trip_exact_pixels_counters_and_timestamps(ring_name):
    with ShmProducer(ring_name, W, H, RandomPattern(W, H, seed=7), fps=200.0, slots=8) as prod:
        cam = ShmCamera("mwir", ring_name)
        watch = Watch(cam)
        with cam:
            watch.until("30 frames", lambda: len(watch.frames) >= 30)
        assert prod.pid is not None
    frames = watch.frames[:30]
    assert cam.format == CameraFormat(W, H, "Mono16", 200.0)
    counters = [f.counter for f in frames]
    if cam.frames_lost_to_overrun == 0:
        assert counters == list(range(counters[0], counters[0] + 30))
    for f in frames:
        assert f.pixels.dtype == np.uint16 and f.pixels.shape == (H, W)
        np.testing.assert_array_equal(f.pixels, RandomPattern(W, H, seed=7)(f.counter))
        assert f.camera == "mwir"
        assert f.meta["t_write_ns"] <= f.t_host_ns
    t_host = [f.t_host_ns for f in frames]
    t_dev = [f.t_device_ns for f in frames]
    assert all(b > a for a, b in itertools.pairwise(t_host))
    assert all(b > a for a, b in itertools.pairwise(t_dev))
    # Paced at 200 fps on absolute time: the writer's stamps are 5 ms apart on average.
    span_s = (t_dev[-1] - t_dev[0]) / 1e9 / (counters[-1] - counters[0])
    assert span_s == pytest.approx(0.005, rel=0.2)


def test_skipped_counters_are_counted_as_drops(ring_name):
    drops = {40, 41, 42, 60}
    prod = ShmProducer(
        ring_name, W, H, StampPattern(W, H), fps=400.0, drop_counters=drops, max_frames=80
    )
    with prod:
        cam = ShmCamera("lwir", ring_name)
        watch = Watch(cam)
        with cam:
            watch.until("counter 70", lambda: bool(watch.frames) and watch.frames[-1].counter >= 70)
            dropped = cam.status().dropped
    got = [f.counter for f in watch.frames]
    first, last = got[0], got[-1]
    link_drops = len([c for c in drops if first < c < last])
    assert link_drops > 0, "reader attached after the drops; the test proves nothing"
    assert dropped == link_drops + cam.frames_lost_to_overrun
    if cam.frames_lost_to_overrun == 0:
        assert got == [c for c in range(first, last + 1) if c not in drops]
    assert not set(got) & drops


class HeldBackOnce:
    """Picklable render whose frame ``at`` takes ``hold_s`` (a host that held the camera's
    process back for that long, past the camera's buffer)."""

    def __init__(self, at: int, hold_s: float) -> None:
        self.at, self.hold_s = at, hold_s
        self.stamps = StampPattern(W, H)

    def __call__(self, counter: int) -> np.ndarray:
        if counter == self.at:
            time.sleep(self.hold_s)  # the simulated fault, not a synchronisation
        return self.stamps(counter)


def test_a_camera_held_back_past_its_buffer_loses_the_frames_it_skipped(ring_name):
    """Held back 0.5 s at 100 frames/s (twice the camera's 0.25 s buffer), the camera skips
    the counters it could not deliver in time; the producer counts them, and the reader sees
    exactly those as the camera's gap."""
    prod = ShmProducer(ring_name, W, H, HeldBackOnce(30, 0.5), fps=100.0, slots=64)
    with prod:
        cam = ShmCamera("lwir", ring_name)
        watch = Watch(cam)
        with cam:
            watch.until("a frame after the hold", lambda: prod.frames_skipped > 0)
            skipped = prod.frames_skipped
            watch.until("frames after the gap", lambda: watch.frames[-1].counter > 30 + skipped + 5)
            dropped = cam.status().dropped - cam.frames_lost_to_overrun
    got = [f.counter for f in watch.frames]
    assert got[0] < 30, "reader attached after the hold; the test proves nothing"
    assert 0.5 / 0.01 - 5 <= skipped + 1 <= 0.5 / 0.01 + 5  # ~49 frame times behind
    assert dropped == skipped
    if cam.frames_lost_to_overrun == 0:
        gaps = [b - a - 1 for a, b in itertools.pairwise(got) if b - a > 1]
        assert gaps == [skipped]


def test_overrun_when_reader_is_slow_jumps_to_newest(ring_name):
    writer = ShmFrameWriter(ring_name, W, H, slots=4, fps=None)
    entered, release = threading.Event(), threading.Event()
    cam = ShmCamera("mwir", ring_name)
    watch = Watch(cam)

    def slow(frame: Frame) -> None:
        if frame.counter == 100:
            entered.set()
            release.wait(10)

    cam.subscribe(slow)
    try:
        with cam:
            watch.until("streaming", lambda: cam.format is not None)
            writer.write(np.full((H, W), 1, np.uint16), counter=100)
            assert entered.wait(10)
            for k in range(1, 11):  # 10 frames into a 4-slot ring while the reader is busy
                writer.write(np.full((H, W), k + 1, np.uint16), counter=100 + k)
            release.set()
            watch.until("newest frame", lambda: watch.frames[-1].counter == 110)
            st = cam.status()
    finally:
        writer.close()
    assert [f.counter for f in watch.frames] == [100, 110]
    assert watch.frames[-1].pixels[0, 0] == 11
    assert cam.overruns >= 1
    assert cam.frames_lost_to_overrun == 9
    assert st.dropped == 9  # the camera counter shows the same 9 missing frames


def test_silent_writer_goes_stale_then_streams_again(ring_name):
    with ShmProducer(ring_name, W, H, StampPattern(W, H), fps=200.0) as prod:
        cam = ShmCamera("mwir", ring_name, stale_after_s=0.3, reopen_after_s=0.2)
        watch = Watch(cam)
        with cam:
            watch.until("frames", lambda: len(watch.frames) >= 5)
            prod.pause()
            watch.until("stale", lambda: DeviceState.STALE in watch.states)
            watch.until("reopened while silent", lambda: cam.status().reconnects >= 1)
            n = len(watch.frames)
            prod.resume()
            watch.until("frames after resume", lambda: len(watch.frames) >= n + 5)
            st = cam.status()
    assert st.state is DeviceState.STREAMING
    assert st.reconnects >= 1  # stale -> reopened
    assert st.dropped == 0  # a pause is not a loss: the counter continues without a gap


def test_writer_killed_and_restarted_is_a_counted_reconnect(ring_name):
    prod = ShmProducer(ring_name, W, H, RandomPattern(W, H, seed=3), fps=200.0, first_counter=5)
    prod.start()
    cam = ShmCamera("mwir", ring_name, stale_after_s=1.0)
    watch = Watch(cam)
    try:
        with cam:
            watch.until("frames", lambda: len(watch.frames) >= 5)
            old_pid = prod.pid
            prod.kill()  # camera lost without goodbye: ring left behind, writer pid dead
            watch.until("link lost", lambda: watch.states[-1] is not DeviceState.STREAMING)
            n = len(watch.frames)
            prod.start()  # camera back: new process, new session, counter restarts at 5
            watch.until("frames after restart", lambda: len(watch.frames) >= n + 5)
            st = cam.status()
    finally:
        prod.close()
    assert prod.pid != old_pid
    assert st.reconnects == 1
    assert st.dropped == 0  # the counter restart is a reset, not thousands of drops
    after = watch.frames[n:]
    np.testing.assert_array_equal(after[-1].pixels, RandomPattern(W, H, seed=3)(after[-1].counter))


def test_clean_stop_is_seen_at_once_and_retried(ring_name):
    prod = ShmProducer(ring_name, W, H, StampPattern(W, H), fps=200.0)
    prod.start()
    cam = ShmCamera("mwir", ring_name, stale_after_s=5.0, backoff_s=(0.05, 0.1))
    watch = Watch(cam)
    try:
        with cam:
            watch.until("frames", lambda: len(watch.frames) >= 3)
            prod.stop()
            watch.until("closed", lambda: any("writer closed" in e for e in watch.errors))
            watch.until("retrying", lambda: "not running" in watch.errors[-1])
            prod.start()
            watch.until("reconnect", lambda: cam.status().reconnects == 1)
    finally:
        prod.close()


def test_not_a_ring_is_refused_with_a_clear_error(ring_name):
    from multiprocessing import shared_memory

    shm = shared_memory.SharedMemory(ring_name, create=True, size=4096)
    try:
        cam = ShmCamera("mwir", ring_name, max_attempts=1)
        done = queue.Queue()
        cam.subscribe_status(lambda st: st.state is DeviceState.FAILED and done.put(st))
        cam.open()
        st = done.get(timeout=10)
        cam.close()
    finally:
        shm.close()
        shm.unlink()
    assert "not a version-1 frame ring" in st.last_error


@pytest.mark.parametrize(
    "kwargs, match",
    [
        ({"shm_name": "a/b"}, "plain name"),
        ({"shm_name": "x", "reuse_buffers": 1}, "reuse_buffers"),
    ],
)
def test_bad_configuration_names_the_value(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ShmCamera("mwir", **kwargs)


def test_writer_rejects_wrong_frames(ring_name):
    with ShmFrameWriter(ring_name, W, H, slots=2) as writer:
        with pytest.raises(ValueError, match=r"shape \(10, 10\)"):
            writer.write(np.zeros((10, 10), np.uint16), 0)
        with pytest.raises(ValueError, match="float64"):
            writer.write(np.zeros((H, W)), 0)


def test_reused_buffers_are_round_robin(ring_name):
    writer = ShmFrameWriter(ring_name, W, H, slots=8)
    cam = ShmCamera("mwir", ring_name, reuse_buffers=3)
    watch = Watch(cam)
    try:
        with cam:
            watch.until("attached", lambda: cam.format is not None)
            for c in range(4):
                writer.write(np.full((H, W), c, np.uint16), counter=c)
            watch.until("4 frames", lambda: len(watch.frames) == 4)
    finally:
        writer.close()
    arrays = [f.pixels for f in watch.frames]
    assert arrays[3] is arrays[0] and arrays[1] is not arrays[0]
    assert [int(a[0, 0]) for a in arrays[1:]] == [1, 2, 3]
