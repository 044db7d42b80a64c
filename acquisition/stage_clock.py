"""Where a live frame's time goes: the per-stage clock of a camera's measurement thread.

A frame's way from the camera to its SNR (docs/engine.md), as stages:

============ ===========================================================================
grab         the camera wrote the frame -> the driver copied it out (known where the camera
             stamps its write: the shared-memory ring; before receipt, not in the latency)
ring         received -> the measurement thread holds its copy: the device thread's push,
             the wait while the measurement thread finishes earlier frames (``backlog``) or
             wakes up and takes the interpreter lock, and the copy out
correction   the calibration and the background reference applied to the pixels read (lazy)
             and a reference capture being fed
tracking     the tracker (both tracks while a correction is on): finding, segmenting and
             judging the object, commands
eq4          Eq. (4) of the object found: its background (wing profile, rim or extent rim),
             peak, mean and std
statistics   the running SNR statistics, the section 6 noise, the sky temperature, the stop
             table and the model's background following the sky
recording    the frame, its measurement and events queued for the recorder
handover     what the console reads: the published measurement and chart series, the
             measurement listeners, the click's news
============ ===========================================================================

``latency`` is receipt -> done (ring + correction + ... + handover), the figure the status
reports. Of the ring, ``push`` is the device thread's part (receipt -> published in the ring)
and ``backlog`` the wait for the measurement thread to finish earlier frames. The measurement
thread's own time from the moment the frame was there for it (``max(ring push, end of the
previous frame)``) to the end is split by the thread's scheduler statistics
(``/proc/thread-self/schedstat``, Linux): ``cpu`` (running), ``runq`` (runnable, waiting for a
core: other threads and processes) and ``blocked`` (the rest: waiting for the interpreter lock,
another lock or I/O). A stage's p99 says which stage is slow; ``push``, ``backlog``, ``runq``
and ``blocked`` say why a slow frame waited.

Timing costs a clock read per stage change (about ten a frame) and one read of the thread's
scheduler statistics per frame. The measurement code marks its stages with :func:`enter`, which
does nothing on a thread without a clock (a replay, a batch, a test).
"""

from __future__ import annotations

import math
import os
import threading
import time

import numpy as np

CORRECTION, TRACKING, EQ4, STATISTICS, RECORDING, HANDOVER = range(6)
ENGINE_STAGES = ("correction", "tracking", "eq4", "statistics", "recording", "handover")
STAGES = ("grab", "ring", *ENGINE_STAGES)
"""The stages in a frame's order (module docstring)."""
COLUMNS = (*STAGES, "latency", "push", "backlog", "cpu", "runq", "blocked")
"""Every per-frame figure kept: the stages, the latency, and the ring's and the measurement
thread's waits split (module docstring)."""

_GRAB, _RING = 0, 1
_FIRST_ENGINE = 2
_LATENCY, _PUSH, _BACKLOG, _CPU, _RUNQ, _BLOCKED = range(len(STAGES), len(COLUMNS))
UNKNOWN = -1
"""A figure not measured for a frame (no camera write time; no scheduler statistics)."""

_local = threading.local()
_attached = 0  # clocks attached to threads in this process: none in a replay or a batch
_count_lock = threading.Lock()


def enter(stage: int) -> int:
    """The time since the last change goes to the stage that was running; ``stage`` runs
    from now. Returns the stage that was running (enter it again after a nested one), or -1
    on a thread without a clock (where this costs one test of a global, in a process without
    any, or one attribute lookup)."""
    if not _attached:
        return -1
    clock = getattr(_local, "clock", None)
    if clock is None:
        return -1
    return clock.enter(stage)


class _SchedStat:
    """This thread's CPU time and run-queue wait (ns) from ``/proc/thread-self/schedstat``."""

    def __init__(self) -> None:
        try:
            self._fd: int | None = os.open("/proc/thread-self/schedstat", os.O_RDONLY)
        except OSError:  # not Linux, or no scheduler statistics: cpu/runq/blocked unknown
            self._fd = None

    def read(self) -> tuple[int, int] | None:
        if self._fd is None:
            return None
        try:
            run, wait, _ = os.pread(self._fd, 96, 0).split()
        except (OSError, ValueError):
            return None
        return int(run), int(wait)

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None


class StageClock:
    """The per-frame stage times of one camera's measurement thread, the last ``frames``.

    The owner thread calls :meth:`attach` once, then per frame :meth:`begin`, :meth:`enter`
    (directly or through the module's :func:`enter`) and :meth:`end`; :meth:`summary` may be
    called from any thread.
    """

    def __init__(self, frames: int = 4096) -> None:
        self._rows = np.full((int(frames), len(COLUMNS)), UNKNOWN, np.int64)
        self._n = 0  # frames ended so far
        self._lock = threading.Lock()
        self._acc = [0] * len(ENGINE_STAGES)
        self._stage = -1
        self._t = 0
        self._t_host = self._t_ring = self._t_pop = self._grab = 0
        self._prev_end = 0
        self._sched: _SchedStat | None = None
        self._prev_sched: tuple[int, int] | None = None

    # ------------------------------------------------------------------ owner thread
    def attach(self) -> None:
        """Make this the clock of the calling thread (the measurement thread)."""
        global _attached
        with _count_lock:
            _attached += 1
        _local.clock = self
        self._sched = _SchedStat()
        self._prev_sched = self._sched.read()
        self._prev_end = time.monotonic_ns()

    def detach(self) -> None:
        global _attached
        if getattr(_local, "clock", None) is self:
            _local.clock = None
            with _count_lock:
                _attached -= 1
        if self._sched is not None:
            self._sched.close()

    def begin(self, t_host_ns: int, t_ring_ns: int, grab_ns: int = UNKNOWN) -> None:
        """A frame received at ``t_host_ns`` (and published in the ring at ``t_ring_ns``) is
        in the measurement thread's hands now; ``grab_ns``: its grab time if known."""
        now = time.monotonic_ns()
        self._t_host, self._t_ring, self._t_pop, self._grab = t_host_ns, t_ring_ns, now, grab_ns
        acc = self._acc
        for i in range(len(acc)):
            acc[i] = 0
        self._stage, self._t = -1, now

    def enter(self, stage: int) -> int:
        now = time.monotonic_ns()
        prev = self._stage
        if prev >= 0:
            self._acc[prev] += now - self._t
        self._stage, self._t = stage, now
        return prev

    def end(self) -> int:
        """The frame is done; returns its latency (ns, receipt -> now)."""
        now = time.monotonic_ns()
        if self._stage >= 0:
            self._acc[self._stage] += now - self._t
        self._stage = -1
        sched = self._sched.read() if self._sched is not None else None
        row = [UNKNOWN] * len(COLUMNS)
        row[_GRAB] = self._grab
        row[_RING] = self._t_pop - self._t_host
        row[_FIRST_ENGINE : _FIRST_ENGINE + len(self._acc)] = self._acc
        row[_LATENCY] = now - self._t_host
        ready = self._t_ring if self._t_ring > 0 else self._t_host
        if self._t_ring > 0:
            row[_PUSH] = self._t_ring - self._t_host
        row[_BACKLOG] = max(0, self._prev_end - ready)
        prev = self._prev_sched
        if sched is not None and prev is not None:
            cpu, runq = sched[0] - prev[0], sched[1] - prev[1]
            row[_CPU], row[_RUNQ] = cpu, runq
            row[_BLOCKED] = max(0, now - max(ready, self._prev_end) - cpu - runq)
        self._prev_sched, self._prev_end = sched, now
        with self._lock:
            self._rows[self._n % len(self._rows)] = row
            self._n += 1
        return row[_LATENCY]

    # ------------------------------------------------------------------ any thread
    def reset(self) -> None:
        """Forget the frames timed so far (a benchmark's start after its warm-up)."""
        with self._lock:
            self._n = 0

    @property
    def frames(self) -> int:
        """Frames timed so far."""
        with self._lock:
            return self._n

    def latency_ms(self, last: int = 1000) -> tuple[float, float]:
        """The median and 99th percentile of the last ``last`` frames' latency (ms; NaN before
        the first frame): the figures the console's status reports."""
        with self._lock:
            n, size = self._n, len(self._rows)
            k = min(n, size, int(last))
            idx = np.arange(n - k, n) % size
            latency = self._rows[idx, _LATENCY].astype(float)
        if not latency.size:
            return (math.nan, math.nan)
        p50, p99 = np.percentile(latency, [50, 99]) / 1e6
        return (float(p50), float(p99))

    def rows(self) -> np.ndarray:
        """The kept frames' figures (ns; ``UNKNOWN`` where not measured), oldest first:
        columns :data:`COLUMNS`."""
        with self._lock:
            n, size = self._n, len(self._rows)
            if n <= size:
                return self._rows[:n].copy()
            i = n % size
            return np.concatenate([self._rows[i:], self._rows[:i]])

    def summary(self) -> dict:
        """Per figure of :data:`COLUMNS`: ``p50_ms`` and ``p99_ms`` over the kept frames, and
        ``slowest_ms``, its mean over the slowest 1 % of them by latency (what a slow frame
        spent where); null where not measured. Plus ``frames``, the frames it covers."""
        rows = self.rows()
        out: dict = {"frames": len(rows)}
        if not len(rows):
            return out
        latency = rows[:, _LATENCY]
        slow = rows[latency >= np.percentile(latency, 99)]
        for k, name in enumerate(COLUMNS):
            col = rows[:, k]
            known = col[col != UNKNOWN]
            slow_known = slow[:, k][slow[:, k] != UNKNOWN]
            out[name] = {
                "p50_ms": _ms(np.percentile(known, 50)) if known.size else None,
                "p99_ms": _ms(np.percentile(known, 99)) if known.size else None,
                "slowest_ms": _ms(slow_known.mean()) if slow_known.size else None,
            }
        return out


def _ms(ns: float) -> float | None:
    v = float(ns) / 1e6
    return round(v, 4) if math.isfinite(v) else None
