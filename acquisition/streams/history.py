"""Bounded, thread-safe histories of scalar readings, interpolated at frame times.

Range and drone position for a frame are found by linear interpolation on the common monotonic clock
(docs/architecture.md, "Time"): GPS arrives at 10 Hz, the rangefinder whenever it fires, and frames
at 30-60 Hz. The raw readings are kept by the recorder; this holds only a short history for the
interpolation.
"""

from __future__ import annotations

import bisect
import threading
from collections import deque


class ScalarHistory:
    """The last ``maxlen`` (t_ns, value) pairs of one quantity, appended in time order.

    ``value_at(t_ns)`` interpolates linearly between the two readings around ``t_ns``; outside
    the history it holds the nearest reading if it is at most ``max_gap_ns`` away, else ``None``
    (a stale reading is not a range).
    """

    def __init__(self, maxlen: int = 4096, max_gap_ns: int = 2_000_000_000) -> None:
        self._t: deque[int] = deque(maxlen=maxlen)
        self._v: deque[float] = deque(maxlen=maxlen)
        self._lock = threading.Lock()
        self.max_gap_ns = max_gap_ns

    def append(self, t_ns: int, value: float) -> None:
        with self._lock:
            if self._t and t_ns < self._t[-1]:
                raise ValueError(f"reading at {t_ns} ns is older than the last one ({self._t[-1]})")
            self._t.append(t_ns)
            self._v.append(float(value))

    def __len__(self) -> int:
        return len(self._t)

    def latest(self) -> tuple[int, float] | None:
        with self._lock:
            return (self._t[-1], self._v[-1]) if self._t else None

    def value_at(self, t_ns: int) -> float | None:
        with self._lock:
            if not self._t:
                return None
            i = bisect.bisect_left(self._t, t_ns)
            n = len(self._t)
            if i < n and self._t[i] == t_ns:
                return self._v[i]
            if i == 0:
                return self._v[0] if self._t[0] - t_ns <= self.max_gap_ns else None
            if i == n:
                return self._v[-1] if t_ns - self._t[-1] <= self.max_gap_ns else None
            t0, t1 = self._t[i - 1], self._t[i]
            if t1 - t0 > 2 * self.max_gap_ns:
                return None
            v0, v1 = self._v[i - 1], self._v[i]
            return v0 + (v1 - v0) * (t_ns - t0) / (t1 - t0)
