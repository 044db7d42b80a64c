"""The display's frame feed: every new frame once, copied into arrays it reuses, and the count of
frames shown against frames delivered (no Qt needed: the feed and the rates are plain code; the
status bar's label is checked on the console in test_console.py)."""

from __future__ import annotations

import numpy as np

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
    assert feed.newest() is None  # nothing delivered yet
    arrays = set()
    for k in range(10):
        cam.push(k)
        frame = feed.newest()
        assert frame is not None and frame.seq == k and (frame.pixels == k).all()
        assert feed.newest() is None  # nothing new: nothing copied
        if k >= 1:
            arrays.add(id(frame.pixels))
    assert cam.copies == 10
    assert len(arrays) == BUFFERS  # after the first frame, three arrays in turn
    assert (feed.shown, feed.delivered) == (10, 10)


def test_frames_that_arrived_between_two_looks_are_counted_as_not_shown():
    cam = RingCamera()
    feed = FrameFeed(cam)
    cam.push(0)
    feed.newest()
    for k in (1, 2, 3):  # the display was late by three frame periods
        cam.push(k)
    frame = feed.newest()
    assert frame is not None and frame.seq == 3
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
        assert feed.newest() is player.frame  # the player's own array: no copy
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
