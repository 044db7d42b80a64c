"""Frames a camera delivered per second, counted where its frames are processed.

The rate a camera header shows is what the pipeline got, not what the driver was asked for: a
camera throttled by its link, a simulated day slowed to the console's pace, a replay at 8x, a
camera that stalled. The processing thread (a live pipeline's measurement thread, a replay's
worker) notes each frame it takes with its ``seq`` (the ring's count of frames received: a jump
is frames delivered that the processing lost to a ring overrun, delivered all the same) and the
time it took it; the rate is the frames between the oldest and newest noted in the last
:data:`WINDOW_S` over the time between them, and once the next frame is overdue (a stall) over
the time since the oldest instead, so a stalled camera's rate falls to 0.
"""

from __future__ import annotations

import threading
import time
from collections import deque

WINDOW_S = 2.0


class DeliveredRate:
    """The frames delivered per second over the last ``window_s`` seconds (module docstring).
    :meth:`frame` on the processing thread, :meth:`per_s` on any."""

    def __init__(self, window_s: float = WINDOW_S) -> None:
        if not window_s > 0:
            raise ValueError(f"the rate's window must be positive seconds, got {window_s}")
        self.window_ns = round(window_s * 1e9)
        self._lock = threading.Lock()
        self._frames: deque[tuple[int, int]] = deque()  # (t_ns, frames delivered up to it)
        self._count = 0
        self._last_seq: int | None = None

    def frame(self, seq: int, t_ns: int | None = None) -> None:
        """A frame taken for processing at monotonic ``t_ns`` (default: now). A ``seq`` that
        does not grow (a restart: a replay's seek) counts as one frame."""
        t = time.monotonic_ns() if t_ns is None else t_ns
        with self._lock:
            last, self._last_seq = self._last_seq, seq
            self._count += seq - last if last is not None and seq > last else 1
            self._frames.append((t, self._count))
            while self._frames and self._frames[0][0] < t - self.window_ns:
                self._frames.popleft()

    def per_s(self, now_ns: int | None = None) -> float:
        """Frames delivered per second at monotonic ``now_ns`` (default: now); 0.0 before two
        frames, and once none came for the whole window."""
        now = time.monotonic_ns() if now_ns is None else now_ns
        with self._lock:
            frames = [f for f in self._frames if f[0] >= now - self.window_ns]
        if len(frames) < 2:
            return 0.0
        (t0, n0), (t1, n1) = frames[0], frames[-1]
        delivered = n1 - n0
        if t1 <= t0 or delivered <= 0:
            return 0.0
        period = (t1 - t0) / delivered
        # Until the next frame is overdue the span of the frames noted; after, the wait too.
        span = max(t1 - t0, now - t0 - period)
        return delivered / (span / 1e9)
