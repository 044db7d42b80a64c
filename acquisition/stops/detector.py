"""Range stops: cutting a flight into hovers, and the 100-frame summary of each (paper section 7).

A stop is the drone hovering at a surveyed range (37, 126, 199, 336, 393, 451, 508 m in the paper).
:class:`StopDetector` finds them from the laser rangefinder's slant ranges and/or the GPS slant
range (:func:`snrmon.acquisition.geo.projection.gps_slant_range_m`), and takes the operator's manual
marks.

Detection rules (every number is a :class:`StopConfig` field):

- Each source (``lrf``, ``gps``) keeps its readings of the last ``steady_s`` seconds, and the
  last one before them (so a slow source still spans the whole time).
- A source is *steady* when its window spans at least ``coverage`` x ``steady_s`` seconds, holds
  at least ``min_readings`` readings, and at least ``steady_fraction`` of them lie within its
  tolerance (``lrf_tolerance_m`` / ``gps_tolerance_m``) of the window's median: one outlier shot
  (a bird, a missed target) does not break a hover.
- A stop starts when every source that has ``min_readings`` readings in its window is steady (at
  least one must). Its start time is the first reading within tolerance in the steady window (the
  later of the two sources'): the hover began then, not when it was confirmed (``t_confirmed_ns``).
  Transit looks steady for tolerance/speed seconds, so the start is that early at most.
- A stop ends at the first of ``end_readings`` consecutive readings of one source that lie
  farther than its tolerance from the median of that source's readings during the stop.
- The stop's ranges are the medians of each source's readings during the stop (None when the
  source gave none).
- Manual marks: :meth:`StopDetector.mark_stop` ends any open stop and opens a manual one, which
  only the operator ends (:meth:`StopDetector.end_stop` or the next mark); automatic detection
  is suspended while it is open, its ranges are still the medians of the readings.

:func:`summarise_stop` takes one camera's per-frame :class:`PeakSnr` during a stop and returns the
mean and sample std (ddof=1) of the SNR over the first ``n`` (100) consecutive valid frames, valid
meaning none of the flags rim_contaminated, lost, saturated, edge, undefined (averaging after the
SNR is formed, as the paper insists). When no run of ``n`` exists it says so (``complete`` False)
and summarises the longest run instead.
"""

from __future__ import annotations

import bisect
import math
import statistics
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace

import numpy as np

from snrmon.acquisition.measure.peak_snr import (
    FLAG_EDGE,
    FLAG_LOST,
    FLAG_RIM_CONTAMINATED,
    FLAG_SATURATED,
    FLAG_UNDEFINED,
    PeakSnr,
)
from snrmon.drivers.rangefinder.reading import RangeReading, RangeStatus

#: A frame carrying any of these is not valid for a stop's summary.
INVALID_FLAGS: frozenset[str] = frozenset(
    {FLAG_RIM_CONTAMINATED, FLAG_LOST, FLAG_SATURATED, FLAG_EDGE, FLAG_UNDEFINED}
)
SOURCES = ("lrf", "gps")


@dataclass(frozen=True, slots=True)
class Stop:
    """One hover. Times on the common ``time.monotonic_ns()`` clock; ``t_end_ns`` None while the
    stop is open. Ranges in metres, medians over the stop, None without readings."""

    index: int
    t_start_ns: int
    t_end_ns: int | None
    lrf_range_m: float | None
    gps_range_m: float | None
    manual: bool
    t_confirmed_ns: int | None = None

    def contains(self, t_ns: int) -> bool:
        """True when ``t_ns`` is within the stop (end excluded; an open stop has no end)."""
        return self.t_start_ns <= t_ns and (self.t_end_ns is None or t_ns < self.t_end_ns)


@dataclass(frozen=True)
class StopConfig:
    """The detection rules' numbers (module docstring)."""

    steady_s: float = 3.0
    lrf_tolerance_m: float = 1.0
    gps_tolerance_m: float = 2.5
    min_readings: int = 3
    steady_fraction: float = 0.9
    coverage: float = 0.8
    end_readings: int = 3

    def __post_init__(self) -> None:
        for name in ("steady_s", "lrf_tolerance_m", "gps_tolerance_m"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"stop detection {name} must be > 0, got {v}")
        if self.min_readings < 2 or self.end_readings < 1:
            raise ValueError(
                f"stop detection needs min_readings >= 2 and end_readings >= 1, got "
                f"{self.min_readings}, {self.end_readings}"
            )
        for name in ("steady_fraction", "coverage"):
            v = getattr(self, name)
            if not 0 < v <= 1:
                raise ValueError(f"stop detection {name} must be in (0, 1], got {v}")

    def tolerance_m(self, source: str) -> float:
        return self.lrf_tolerance_m if source == "lrf" else self.gps_tolerance_m

    def at_speed(self, speed: float) -> StopConfig:
        """These rules on a flight replayed or simulated at ``speed`` x real time: "steady for
        3 s" means 3 s of the flight, so 3 / speed s of the host clock the detector runs on."""
        if not speed > 0:
            raise ValueError(f"speed must be > 0, got {speed}")
        return replace(self, steady_s=self.steady_s / speed)


@dataclass
class _Open:
    index: int
    t_start_ns: int
    manual: bool
    t_confirmed_ns: int | None
    # Kept sorted: the median is read on every reading, and a stop can last an hour (36,000
    # readings a source at 10 Hz), so it must not cost a sort each time.
    ranges: dict[str, list[float]] = field(default_factory=lambda: {s: [] for s in SOURCES})
    departures: dict[str, list[tuple[int, float]]] = field(
        default_factory=lambda: {s: [] for s in SOURCES}
    )

    def add(self, source: str, ranges: Iterable[float]) -> None:
        for r in ranges:
            bisect.insort(self.ranges[source], r)

    def median(self, source: str) -> float | None:
        """The median of the stop's readings from ``source`` (as ``statistics.median``)."""
        v = self.ranges[source]
        n = len(v)
        if n == 0:
            return None
        return v[n // 2] if n % 2 else (v[n // 2 - 1] + v[n // 2]) / 2

    def snapshot(self, t_end_ns: int | None) -> Stop:
        return Stop(
            self.index,
            self.t_start_ns,
            t_end_ns,
            self.median("lrf"),
            self.median("gps"),
            self.manual,
            self.t_confirmed_ns,
        )


class StopDetector:
    """Live stop detection from range readings (feed them in time order per source)."""

    def __init__(self, config: StopConfig | None = None, **settings) -> None:
        if config is not None and settings:
            raise ValueError("give either config or settings, not both")
        self.config = config if config is not None else StopConfig(**settings)
        self._windows: dict[str, deque[tuple[int, float]]] = {s: deque() for s in SOURCES}
        self._closed: list[Stop] = []
        self._open: _Open | None = None

    # ----------------------------------------------------------------------------- input
    def add_range(self, t_ns: int, range_m: float, source: str = "lrf") -> Stop | None:
        """One slant range (m) from ``source`` ("lrf" or "gps"). Returns the stop that started
        or ended on this reading, else None."""
        if source not in SOURCES:
            raise ValueError(f"range source must be one of {SOURCES}, got {source!r}")
        if not (math.isfinite(range_m) and range_m > 0):
            raise ValueError(f"{source} range must be a positive number of metres, got {range_m}")
        t_ns = int(t_ns)
        win = self._windows[source]
        win.append((t_ns, float(range_m)))
        horizon = t_ns - round(self.config.steady_s * 1e9)
        # Keep the last reading at or before the horizon too: a slow source (a rangefinder shot
        # per second) then still spans the whole steady time.
        while len(win) > 1 and win[1][0] <= horizon:
            win.popleft()
        if self._open is not None:
            return self._extend(source, t_ns, float(range_m))
        return self._maybe_start(t_ns)

    def add_reading(self, reading: RangeReading) -> Stop | None:
        """A rangefinder reading; shots without a range (no target, error) are skipped."""
        if reading.status is not RangeStatus.OK or reading.range_m is None:
            return None
        return self.add_range(reading.t_host_ns, reading.range_m, "lrf")

    def add_gps_range(self, t_ns: int, range_m: float) -> Stop | None:
        """A GPS fix's slant range from the camera site
        (:func:`snrmon.acquisition.geo.projection.gps_slant_range_m`, computed once by the caller,
        which keeps it for the frames' ranges too); a range of 0 or less is skipped."""
        return None if range_m <= 0 else self.add_range(t_ns, range_m, "gps")

    def mark_stop(self, t_ns: int) -> Stop:
        """The operator marks a stop at ``t_ns``: any open stop ends there, a manual one opens."""
        t_ns = int(t_ns)
        since = {s: [r for t, r in w if t >= t_ns] for s, w in self._windows.items()}
        self.end_stop(t_ns)
        self._open = _Open(self._next_index(), t_ns, True, t_ns)
        for source, ranges in since.items():
            self._open.add(source, ranges)
        return self._open.snapshot(None)

    def end_stop(self, t_ns: int) -> Stop | None:
        """End the open stop (manual or automatic) at ``t_ns``; returns it, None if none."""
        if self._open is None:
            return None
        stop = self._open.snapshot(max(int(t_ns), self._open.t_start_ns))
        self._closed.append(stop)
        self._open = None
        for win in self._windows.values():
            win.clear()  # the next stop is judged on readings after this one only
        return stop

    # ----------------------------------------------------------------------------- output
    @property
    def current(self) -> Stop | None:
        """The open stop, None between stops."""
        return None if self._open is None else self._open.snapshot(None)

    @property
    def stops(self) -> list[Stop]:
        """Every stop so far, the open one last (``t_end_ns`` None)."""
        return [*self._closed, *([self._open.snapshot(None)] if self._open is not None else [])]

    # ----------------------------------------------------------------------------- rules
    def _next_index(self) -> int:
        return len(self._closed) + (1 if self._open is not None else 0)

    def _steady(self, source: str, t_now: int) -> bool | None:
        """True/False for a source with enough readings; None when it has too few to judge."""
        cfg = self.config
        win = self._windows[source]
        if len(win) < cfg.min_readings:
            return None
        if t_now - win[0][0] < cfg.coverage * cfg.steady_s * 1e9:
            return False
        ranges = [r for _, r in win]
        med = statistics.median(ranges)
        tol = cfg.tolerance_m(source)
        inside = sum(abs(r - med) <= tol for r in ranges)
        return inside >= cfg.steady_fraction * len(ranges)

    def _maybe_start(self, t_now: int) -> Stop | None:
        verdicts = {s: self._steady(s, t_now) for s in SOURCES}
        judged = [s for s, v in verdicts.items() if v is not None]
        if not judged or not all(verdicts[s] for s in judged):
            return None
        steady: dict[str, list[tuple[int, float]]] = {}
        for source in judged:
            win = self._windows[source]
            med = statistics.median(r for _, r in win)
            tol = self.config.tolerance_m(source)
            steady[source] = [(t, r) for t, r in win if abs(r - med) <= tol]
        # The hover began with the first steady reading (not a stray shot before it); of two
        # sources, the later start is the tighter one (transit looks steady for tolerance/speed).
        t_start = max(readings[0][0] for readings in steady.values())
        self._open = _Open(self._next_index(), t_start, False, t_now)
        for source, readings in steady.items():
            self._open.add(source, (r for _, r in readings))
        return self._open.snapshot(None)

    def _extend(self, source: str, t_ns: int, range_m: float) -> Stop | None:
        op = self._open
        assert op is not None
        if op.manual:
            op.add(source, (range_m,))
            return None
        ref = op.median(source)
        if ref is None or abs(range_m - ref) <= self.config.tolerance_m(source):
            op.add(source, (range_m,))
            op.departures[source].clear()
            return None
        departing = op.departures[source]
        departing.append((t_ns, range_m))
        if len(departing) < self.config.end_readings:
            return None
        stop = self.end_stop(departing[0][0])
        # The departing readings belong to what follows (transit, or the next hover).
        self._windows[source].extend(departing)
        return stop


def detect_stops(
    lrf: Iterable[tuple[int, float]] = (),
    gps: Iterable[tuple[int, float]] = (),
    config: StopConfig | None = None,
) -> list[Stop]:
    """Offline: feed (t_ns, range_m) series of both sources in time order; every stop found
    (the last may be open)."""
    det = StopDetector(config)
    merged = [(int(t), 0, r, "lrf") for t, r in lrf] + [(int(t), 1, r, "gps") for t, r in gps]
    merged.sort(key=lambda item: (item[0], item[1]))
    for t, _, r, source in merged:
        det.add_range(t, r, source)
    return det.stops


@dataclass(frozen=True, slots=True)
class StopSummary:
    """SNR statistics of one camera at one stop.

    ``n_frames`` valid consecutive frames from ``first`` (index into the stream given);
    ``complete`` True when that is the ``n_wanted`` asked for; otherwise the longest run found
    (``n_frames`` 0 and NaN statistics when there was no valid frame). ``snr_std`` is the sample
    std (ddof=1; NaN for one frame).
    """

    n_frames: int
    n_wanted: int
    complete: bool
    first: int | None
    snr_mean: float
    snr_std: float
    snr_sem: float = math.nan  # the error of the mean: std / sqrt(N_eff) (mean_error)

    @property
    def frames(self) -> slice:
        """The run as a slice of the stream (empty when there was none)."""
        if self.first is None:
            return slice(0, 0)
        return slice(self.first, self.first + self.n_frames)


def is_valid(m: PeakSnr) -> bool:
    """A frame that may enter a stop's statistics: none of :data:`INVALID_FLAGS`, finite SNR."""
    return not (m.flags & INVALID_FLAGS) and math.isfinite(m.snr)


def summarise_stop(frames: Sequence[PeakSnr] | Iterable[PeakSnr], n: int = 100) -> StopSummary:
    """Mean and sample std of the SNR over the first ``n`` consecutive valid frames of one
    camera's stream during a stop (paper section 7: 100 consecutive frames per stop)."""
    if n < 1:
        raise ValueError(f"frames per stop summary must be >= 1, got {n}")
    run_start, run_len = 0, 0
    best_start, best_len = None, 0
    snrs: list[float] = []
    for i, m in enumerate(frames):
        snrs.append(m.snr)
        if is_valid(m):
            if run_len == 0:
                run_start = i
            run_len += 1
            if run_len > best_len:
                best_start, best_len = run_start, run_len
            if run_len == n:
                break
        else:
            run_len = 0
    if best_start is None:
        return StopSummary(0, n, False, None, math.nan, math.nan)
    values = np.asarray(snrs[best_start : best_start + best_len], float)
    std = float(values.std(ddof=1)) if best_len > 1 else math.nan
    return StopSummary(
        best_len, n, best_len == n, best_start, float(values.mean()), std, mean_error(values)
    )


def mean_error(values: Sequence[float] | np.ndarray) -> float:
    """Standard error of the mean of correlated frames: std / sqrt(N_eff) with
    N_eff = N / (1 + 2 sum_k (1 - k/N) rho_k), rho_k the sample autocorrelation summed over
    the initial positive lags (Geyer's rule: up to the first lag where it is <= 0). A hover's
    drift makes the per-frame SNR wander over tens of frames, so N_eff is often well below the
    100 frames; the error bar of a stop against the model is this, not the per-frame std.
    NaN for fewer than 3 values."""
    x = np.asarray(values, float)
    n = x.size
    if n < 3:
        return math.nan
    d = x - x.mean()
    var = float(d @ d) / n
    if var == 0:
        return 0.0
    tau = 1.0
    for k in range(1, n - 1):
        rho = float(d[:-k] @ d[k:]) / (n * var)
        if rho <= 0:
            break
        tau += 2.0 * (1.0 - k / n) * rho
    return float(x.std(ddof=1) / math.sqrt(n / tau))


def frames_in_stop(t_ns: Sequence[int], stop: Stop) -> slice:
    """The slice of a sorted frame-time sequence that falls within ``stop``."""
    lo = bisect.bisect_left(t_ns, stop.t_start_ns)
    hi = len(t_ns) if stop.t_end_ns is None else bisect.bisect_left(t_ns, stop.t_end_ns)
    return slice(lo, hi)
