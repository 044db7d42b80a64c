"""The common clock: every device thread stamps with ``time.monotonic_ns()``; this maps it to UTC.

The monotonic clock never jumps, so frames, range readings and GPS fixes from different threads
can be ordered and interpolated on it. UTC for the record comes from one monotone, piecewise
linear map of that clock (:class:`ClockMap`), a list of rows (``/clock`` in a session file):

* it starts from the host's clock (``source`` "host");
* the receiver's first time (a GPS fix) relabels the whole map by the offset it shows (the host
  clock of a field laptop is often minutes off): every stamp so far moves by the same amount, so
  the intervals between them are unchanged and the writer corrects what it already wrote;
* after that, the map is never stepped: every :data:`REPLAN_S` the median residual (receiver's
  time minus the map's, at the fix's receipt) of the fixes since is removed by a slew, a row from
  now on whose rate differs from 1 by at most :data:`MAX_SLEW` (the residual over
  :data:`SLEW_TAU_S`, or less) until the residual is gone, then rate 1 again.

A row changes the map only from its own start (``time.monotonic_ns()`` when it was planned), so a
time already stamped keeps its UTC, and the map is strictly increasing: ``time`` and ``utc_ns``
increase with ``t_host_ns`` in every stream.
"""

from __future__ import annotations

import statistics
import threading
import time
from dataclasses import dataclass, replace
from datetime import UTC, datetime

import numpy as np

MAX_SLEW = 1e-3
"""The largest rate error a slew applies: 1 ms of UTC per second of host clock (1000 ppm)."""
SLEW_TAU_S = 10.0
"""A residual is removed over this long (host s), or longer where :data:`MAX_SLEW` caps it."""
REPLAN_S = 1.0
"""How often (host s) the slew is planned again from the fixes since (their median residual):
a receipt delayed by a busy host (tens of ms) is one sample among ten, not a correction."""


@dataclass(frozen=True, slots=True)
class ClockReference:
    """One row of the map: from ``monotonic_ns`` on, UTC is ``utc_ns + rate x (t -
    monotonic_ns)`` until ``slew_until_ns``, then rate 1. ``source``: "host" or "gps";
    ``residual_ns``: the receiver's time minus the map's that this row removes (0: none)."""

    monotonic_ns: int
    utc_ns: int
    source: str
    rate: float = 1.0
    slew_until_ns: int = -1
    residual_ns: int = 0

    def utc_at(self, t_ns: int) -> int:
        """UTC ns of ``t_ns`` (at or after this row's start) on this row."""
        dt = t_ns - self.monotonic_ns
        if self.slew_until_ns < 0 or t_ns <= self.slew_until_ns:
            return self.utc_ns + round(self.rate * dt)
        slewed = self.slew_until_ns - self.monotonic_ns
        return self.utc_ns + round(self.rate * slewed) + (t_ns - self.slew_until_ns)


class ClockMap:
    """Maps ``time.monotonic_ns()`` values to UTC nanoseconds since the Unix epoch (the module
    docstring). ``now_ns``: the host clock (a test's simulated one)."""

    def __init__(self, now_ns=time.monotonic_ns) -> None:
        self._lock = threading.Lock()
        self._now_ns = now_ns
        self._rows = [ClockReference(now_ns(), time.time_ns(), "host")]
        self._relabelled_ns = 0  # the first fix's offset, added to every row
        self._residuals: list[int] = []
        self._planned_ns: int | None = None

    @property
    def reference(self) -> ClockReference:
        """The latest row."""
        with self._lock:
            return self._rows[-1]

    def rows(self) -> list[ClockReference]:
        """Every row so far, in time order."""
        with self._lock:
            return list(self._rows)

    def snapshot(self) -> tuple[int, list[ClockReference]]:
        """(:attr:`relabelled_ns`, :meth:`rows`) at one instant."""
        with self._lock:
            return self._relabelled_ns, list(self._rows)

    @property
    def relabelled_ns(self) -> int:
        """The offset the receiver's first time moved the map by (0 before it): a writer adds
        it to the UTC it wrote before."""
        with self._lock:
            return self._relabelled_ns

    def update_from_gps(self, t_host_ns: int, utc: datetime) -> None:
        """A GPS fix's receiver time (received at ``t_host_ns``): the first relabels the map,
        later ones are slewed towards (the module docstring)."""
        utc_ns = int(utc.replace(tzinfo=utc.tzinfo or UTC).timestamp() * 1e9)
        with self._lock:
            residual = utc_ns - self._utc_ns(t_host_ns)
            if self._rows[-1].source == "host":
                self._rows = [replace(r, utc_ns=r.utc_ns + residual) for r in self._rows]
                self._relabelled_ns += residual
                at = max(t_host_ns, self._rows[-1].monotonic_ns)
                self._rows.append(ClockReference(at, self._utc_ns(at), "gps", residual_ns=residual))
                self._planned_ns = self._now_ns()
                return
            self._residuals.append(residual)
            now = self._now_ns()
            if self._planned_ns is not None and now - self._planned_ns < REPLAN_S * 1e9:
                return
            self._planned_ns = now
            self._plan(now, round(statistics.median(self._residuals)))
            self._residuals = []

    def _plan(self, now: int, residual_ns: int) -> None:
        """From ``now`` on: a slew that removes ``residual_ns`` (rate 1 when there is none)."""
        at = max(now, self._rows[-1].monotonic_ns)
        slew = max(-MAX_SLEW, min(MAX_SLEW, residual_ns / (SLEW_TAU_S * 1e9)))
        until = at + round(abs(residual_ns / slew)) if slew else -1
        self._rows.append(
            ClockReference(at, self._utc_ns(at), "gps", 1.0 + slew, until, residual_ns)
        )

    def _utc_ns(self, monotonic_ns: int) -> int:
        rows = self._rows
        i = len(rows) - 1
        while i > 0 and rows[i].monotonic_ns > monotonic_ns:
            i -= 1
        return rows[i].utc_at(monotonic_ns)

    def utc_ns(self, monotonic_ns: int) -> int:
        """UTC ns since the epoch for a monotonic timestamp."""
        with self._lock:
            return self._utc_ns(monotonic_ns)

    def utc_ns_array(self, t_host_ns: np.ndarray) -> np.ndarray:
        """:meth:`utc_ns` of many timestamps at once."""
        return utc_of_rows(rows_array(self.rows()), t_host_ns)

    def utc(self, monotonic_ns: int) -> datetime:
        """UTC as an aware datetime for a monotonic timestamp."""
        return datetime.fromtimestamp(self.utc_ns(monotonic_ns) / 1e9, tz=UTC)


def rows_array(rows: list[ClockReference]) -> np.ndarray:
    """The rows as a structured array of the fields of :class:`ClockReference`."""
    dtype = [
        ("monotonic_ns", "<i8"),
        ("utc_ns", "<i8"),
        ("rate", "<f8"),
        ("slew_until_ns", "<i8"),
    ]
    return np.array([(r.monotonic_ns, r.utc_ns, r.rate, r.slew_until_ns) for r in rows], dtype)


def utc_of_rows(clock: np.ndarray, t_host_ns: np.ndarray) -> np.ndarray:
    """UTC ns of host monotonic times through clock rows (``/clock``): the latest row at or
    before each time (the first for a time before it). Rows without ``rate`` (files before
    format 2.4) are references at rate 1, as they were recorded."""
    t = np.asarray(t_host_ns, dtype=np.int64)
    if len(clock) == 0:
        raise ValueError("the session has no /clock rows: its UTC cannot be mapped")
    order = np.argsort(clock["monotonic_ns"], kind="stable")
    mono = clock["monotonic_ns"][order].astype(np.int64)
    utc = clock["utc_ns"][order].astype(np.int64)
    names = clock.dtype.names or ()
    if "rate" not in names and "source" in names:
        utc = _relabelled_host_rows(mono, utc, clock["source"][order])
    rate = clock["rate"][order] if "rate" in names else np.ones(len(mono))
    until = clock["slew_until_ns"][order] if "slew_until_ns" in names else np.full(len(mono), -1)
    i = np.clip(np.searchsorted(mono, t, side="right") - 1, 0, len(mono) - 1)
    m, u, r, end = mono[i], utc[i], rate[i], until[i]
    slewing = (end < 0) | (t <= end)
    dt = np.where(slewing, t - m, end - m)
    tail = np.where(slewing, 0, t - end)
    return u + np.rint(r * dt).astype(np.int64) + tail


def _relabelled_host_rows(mono: np.ndarray, utc: np.ndarray, source: np.ndarray) -> np.ndarray:
    """A file before format 2.4 stepped from the host's UTC to the receiver's at the first GPS
    row: its host rows before it take that row's offset, as :class:`ClockMap` now relabels
    live, so a stop that began before the first fix does not begin years after it ends."""
    gps = np.flatnonzero(source == b"gps")
    if len(gps) == 0 or gps[0] == 0:
        return utc
    g = gps[0]
    offset = utc[g] - (utc[g - 1] + (mono[g] - mono[g - 1]))
    out = utc.copy()
    out[:g] += offset
    return out
