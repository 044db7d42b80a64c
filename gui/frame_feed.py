"""Each camera's frames for its view: every frame the camera delivers, as long as the display keeps
up, and the count of frames shown against frames delivered when it does not.

The main window's frame timer ticks every few milliseconds (``FRAME_INTERVAL_MS``: a quarter of a
60 fps frame period, so a frame waits at most that long to be drawn and no frame falls between
two ticks). A tick asks each camera for a frame newer than the one shown, which costs a lock and
a comparison when there is none; a new frame is copied into one of three arrays the feed keeps
(a fresh 1.8 MB array per frame would cost its page faults on every frame). The camera's ``seq``
numbers the frames it delivered: a jump of more than one between two frames shown is frames the
display skipped (its event loop was late by a whole frame period), counted and shown in the
status bar (:func:`display_message`), not silently dropped.
"""

from __future__ import annotations

import time
from collections import deque

import numpy as np

from snrmon.acquisition.protocols import CameraView
from snrmon.acquisition.streams.ring import RingFrame

BUFFERS = 3  # the frame shown, the one drawn before it, and the next one


class FrameFeed:
    """The newest frames of one camera for its view, and how many were shown of those
    delivered (since the feed began)."""

    def __init__(self, camera: CameraView) -> None:
        self.camera = camera
        self.shown = 0
        self.delivered = 0
        self._last_seq: int | None = None
        self._buffers: list[np.ndarray] = []
        self._next = 0

    def newest(self) -> RingFrame | None:
        """The camera's newest frame if the view has not shown it yet, else None."""
        out = self._buffers[self._next] if self._buffers else None
        frame = self.camera.latest_frame(unless_seq=self._last_seq, out=out)
        if frame is None:
            return None
        if not self._buffers and frame.pixels.ndim == 2:
            self._buffers = [np.empty_like(frame.pixels) for _ in range(BUFFERS)]
        elif frame.pixels is out:
            self._next = (self._next + 1) % BUFFERS
        last, self._last_seq = self._last_seq, frame.seq
        # Frames delivered since the last one shown; a seq that did not grow is a restart
        # (a replay's seek): one frame.
        self.delivered += frame.seq - last if last is not None and frame.seq > last else 1
        self.shown += 1
        return frame


class DisplayRates:
    """Frames shown and delivered per second per camera over the last ``window_s`` seconds."""

    def __init__(self, window_s: float = 5.0) -> None:
        self.window_s = window_s
        self._samples: deque[tuple[float, dict[str, tuple[int, int]]]] = deque()

    def sample(self, feeds: dict[str, FrameFeed]) -> dict[str, tuple[float, float]]:
        """Record the counts now; {camera: (shown per s, delivered per s)} over the window."""
        now = time.monotonic()
        self._samples.append((now, {n: (f.shown, f.delivered) for n, f in feeds.items()}))
        while len(self._samples) > 2 and now - self._samples[1][0] >= self.window_s:
            self._samples.popleft()
        t0, first = self._samples[0]
        span = now - t0
        if span <= 0:
            return {}
        return {
            n: ((f.shown - first[n][0]) / span, (f.delivered - first[n][1]) / span)
            for n, f in feeds.items()
            if n in first
        }


def display_message(rates: dict[str, tuple[float, float]]) -> tuple[str, bool]:
    """The status bar's text of the frames shown / delivered, and whether frames are being
    skipped (the display shows fewer than the cameras deliver)."""
    if not rates:
        return "", False
    parts = [f"{n.upper()} {shown:.1f}/{delivered:.1f}" for n, (shown, delivered) in rates.items()]
    skipping = any(delivered - shown >= 0.5 for shown, delivered in rates.values())
    text = "frames shown/delivered per s: " + ", ".join(parts)
    return (text + "  (the display is skipping frames)" if skipping else text), skipping
