"""The display's frame feed: every new frame once, copied into arrays it reuses, and the count of
frames shown against frames delivered (no Qt needed: the feed and the rates are plain code; the
status bar's label is checked on the console in test_console.py)."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.streams.ring import FrameRing, RingFrame
from snrmon.drivers.camera.frame import Frame
from snrmon.gui import frame_feed
from snrmon.gui.frame_feed import BUFFERS, DisplayRates, FrameFeed, display_message

H, W = 6, 8


class RingCamera:
    """A camera as the console sees it, over a real frame ring."""

    name = "cam"
    shape = (H, W)

    def __init__(self) -> None:
        self.ring = FrameRing(8, H, W)
        self.copies = 0  # frames copied out for the display

    def push(self, k: int) -> None:
        self.ring.push(Frame(np.full((H, W), k, np.uint16), "cam", k, 1000 + k, None))

    def latest_frame(self, *, unless_seq=None, out=None) -> RingFrame | None:
        frame = self.ring.peek_last(out, unless_seq=unless_seq)
        self.copies += frame is not None
        return frame


def test_each_new_frame_is_given_once_into_reused_arrays():
    cam = RingCamera()
    feed = FrameFeed(cam)
    assert not feed.prepare() and feed.newest() is None  # nothing delivered yet
    arrays = set()
    for k in range(10):
        cam.push(k)
        assert feed.prepare()
        assert not feed.prepare()  # not taken yet: the worker waits for the view
        shown = feed.newest()
        assert shown is not None and shown.frame.seq == k and (shown.frame.pixels == k).all()
        assert feed.newest() is None
        assert not feed.prepare()  # nothing new: nothing copied
        if k >= 1:
            arrays.add(id(shown.frame.pixels))
    assert cam.copies == 10
    assert len(arrays) == BUFFERS  # after the first frame, three arrays in turn
    assert (feed.shown, feed.delivered) == (10, 10)


def test_frames_that_arrived_between_two_looks_are_counted_as_not_shown():
    cam = RingCamera()
    feed = FrameFeed(cam)
    cam.push(0)
    feed.prepare()
    feed.newest()
    for k in (1, 2, 3):  # the display was late by three frame periods
        cam.push(k)
    feed.prepare()
    shown = feed.newest()
    assert shown is not None and shown.frame.seq == 3
    assert (feed.shown, feed.delivered) == (2, 4)


def test_a_replay_that_seeks_back_counts_one_frame():
    class Player:
        name, shape = "cam", (H, W)
        frame: RingFrame | None = None

        def latest_frame(self, *, unless_seq=None, out=None):
            f = self.frame
            return None if f is None or f.seq == unless_seq else f

    player = Player()
    feed = FrameFeed(player)
    for seq in (40, 41, 7, 8):  # a seek from frame 41 back to 7
        player.frame = RingFrame(np.zeros((H, W), np.uint16), seq, seq, 0, None, "cam")
        assert feed.prepare()
        assert feed.newest().frame is player.frame  # the player's own array: no copy
    assert (feed.shown, feed.delivered) == (4, 4)


def test_rates_over_the_window_and_the_status_bar_text(monkeypatch):
    clock = [100.0]
    monkeypatch.setattr(frame_feed.time, "monotonic", lambda: clock[0])
    cam = RingCamera()
    feeds = {"mwir": FrameFeed(cam)}
    rates = DisplayRates(window_s=5.0)
    assert rates.sample(feeds) == {}  # one sample: no span yet
    for second in range(1, 8):
        clock[0] = 100.0 + second
        feeds["mwir"].shown += 57
        feeds["mwir"].delivered += 60
        got = rates.sample(feeds)
    # the window keeps the samples of the last 5 s: 57 and 60 a second
    assert got == {"mwir": (57.0, 60.0)}
    text, skipping = display_message(got)
    assert text == (
        "frames shown/delivered per s: MWIR 57.0/60.0  (the display is skipping frames)"
    )
    assert skipping
    text, skipping = display_message({"mwir": (60.0, 60.0), "lwir": (30.0, 30.0)})
    assert text == "frames shown/delivered per s: MWIR 60.0/60.0, LWIR 30.0/30.0"
    assert not skipping


def _grey_reference(pixels: np.ndarray, fx: int, fy: int, lo: float, hi: float) -> np.ndarray:
    """The grey a shown pixel should have, written from its definition: the mean of its block,
    rounded half up, mapped linearly from [lo, hi] onto 0..255 and truncated."""
    rows, cols = pixels.shape[0] // fy, pixels.shape[1] // fx
    blocks = pixels[: rows * fy, : cols * fx].astype(np.int64).reshape(rows, fy, cols, fx)
    n = fx * fy
    mean = (blocks.sum(axis=(1, 3)) + n // 2) // n
    return np.clip((mean - lo) * 255.0 / (hi - lo), 0, 255).astype(np.int64)


def test_the_worker_thread_makes_each_frame_s_image_as_the_view_asked():
    """The display's worker copies each new frame and makes its screen image (block mean and
    colours) off the GUI thread, at the reduction and with the levels the view asked for."""
    import time

    rng = np.random.default_rng(5)
    cam = RingCamera()
    feed = FrameFeed(cam)
    feed.request = frame_feed.DisplayRequest(2, 3, None, None, False, (990.0, 1030.0))
    worker = frame_feed.DisplayWorker([feed], interval_s=0.001)
    worker.start()
    try:
        for k in range(5):
            pixels = rng.normal(1010.0, 10.0, (H, W)).round().astype(np.uint16)
            cam.ring.push(Frame(pixels, "cam", k, 1000 + k, None))
            deadline, shown = time.monotonic() + 10.0, None
            while shown is None or shown.frame.seq != k:  # until the worker made it ready
                assert time.monotonic() < deadline, f"frame {k} never made ready"
                shown = feed.newest() or shown
            assert shown.levels == (990.0, 1030.0)
            assert shown.image_key == (2, 3, (990.0, 1030.0), None, 65536)
            assert shown.image.shape == (H // 3, W // 2)
            grey = (shown.image & 0xFF).astype(np.int64)
            assert np.array_equal(grey, _grey_reference(pixels, 2, 3, 990.0, 1030.0))
            assert np.array_equal(shown.frame.pixels, pixels)
    finally:
        worker.stop()
    assert (feed.shown, feed.delivered) == (5, 5)


def test_auto_levels_hold_within_the_dead_band_and_restart_when_asked_again():
    from snrmon.gui.levels import AutoLevels, robust_levels

    rng = np.random.default_rng(6)
    sky = rng.normal(1000.0, 8.0, (96, 160)).round().astype(np.uint16)
    auto = AutoLevels(every=3)
    first = auto.levels_of(sky, True, (0.0, 1.0), 0)
    assert first == robust_levels(sky)
    for _ in range(6):  # a sky 1 DN warmer: within the dead band, the levels stay
        assert auto.levels_of(sky + 1, True, (0.0, 1.0), 0) == first
    warm = [auto.levels_of(sky + 40, True, (0.0, 1.0), 0) for _ in range(3)]
    assert warm[-1][0] == pytest.approx(first[0] + 40, abs=1.0)  # beyond it: they follow
    # the operator's levels while auto is off; asked again, the next percentiles apply at once
    assert auto.levels_of(sky, False, (900.0, 1100.0), 0) == (900.0, 1100.0)
    assert auto.levels_of(sky + 1, True, (900.0, 1100.0), 1) == robust_levels(sky + 1)
