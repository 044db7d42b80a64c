"""A flight log's times as the log really has them: gaps, time jumps and rows that disagree.

A drone's or a receiver's log is not tidy. Its own clock has gaps where the recorder paused;
a row next to a gap can carry a UTC that disagrees with its neighbours by seconds; a receiver
before its first fix reports the time of its real-time clock (1980, a week off) and then jumps to
the true time; an autopilot that reboots starts its boot clock again. One such row must never
move the others. Two readers of the same idea:

* :func:`anchored_utc` (the log has a clock of its own beside a coarse UTC, as a DJI export's
  ``time(millisecond)`` beside the whole-second ``datetime(utc)``): each row's UTC is ``anchor +
  t_log``. The log is cut into **segments** at every gap in its clock; every row with a UTC bounds
  the anchor (a whole-second, truncated UTC ``u`` at log time ``t`` says ``u - t <= anchor < u - t
  + 1 s``; rounded, ``u - t - 0.5 s <= anchor < u - t + 0.5 s``); the anchor of a segment is the
  middle of the interval the most of its rows agree on (the largest overlap of their bounds; with
  rows at the log's step, within half a step of the truth), so a row that disagrees is outvoted,
  not averaged in. A segment too short to be trusted on its own (less than ``MIN_SEGMENT_S`` of log
  time, or fewer than ``MIN_SEGMENT_ROWS`` rows), or one whose anchor agrees with the running one,
  continues the running anchor (the clock did not stop, rows are only missing); a long segment that
  disagrees starts a new anchor (the clock stopped while UTC went on). Each anchor is estimated
  from all the rows of its segments; a row whose bounds miss its anchor by more than one step of
  the log's clock is an **outlier**: reported, left out of the estimate, its fix kept on the
  anchor's time.
* :func:`consistent_chain` (every row carries its own UTC, as NMEA sentences and MAVLink times
  do): the rows are cut into segments where the UTC does not advance by about the log's own
  interval (a **gap**: it advanced more; a **jump**: it went back, or forward by more than
  ``MAX_GAP_S``); the log's time is the chain of segments, in file order, each starting after the
  previous one ends and within ``MAX_GAP_S`` of it, that holds the most rows. Rows off that chain
  are outliers: reported and left out.

Both return a :class:`ClockReport`: how many segments, gaps, jumps, anchors and outliers, and the
first few outliers named by row, so an import can say what it found.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

MIN_SEGMENT_S = 3.0
"""A segment shorter than this (log time) cannot set an anchor of its own: with whole-second UTC
it spans too few second boundaries to pin the anchor, and a cluster of short segments around a
recorder hiccup is exactly where the bad rows are."""
MIN_SEGMENT_ROWS = 10
MAX_GAP_S = 6 * 3600.0
"""A forward step of a log's UTC beyond this is a jump of the clock, not a pause of the logger
(a field day's pauses are shorter)."""
EXAMPLES = 5  # outliers named in a report


@dataclass(frozen=True)
class ClockReport:
    """What a log's clock looked like and what was left out of it.

    Attributes:
        rows: rows (or epochs) with a time.
        segments: pieces the log splits into at its gaps and jumps.
        gaps: breaks where the log's clock went on by more than its step (rows missing).
        jumps: breaks where the time went backwards or leapt (the clock itself was wrong).
        anchors: distinct clock anchors (:func:`anchored_utc`; 0 where not used).
        outliers: rows whose time disagrees with their segment: left out of the estimate.
        examples: the first few outliers, each "<where>: <how it disagrees>".
    """

    rows: int
    segments: int
    gaps: int = 0
    jumps: int = 0
    anchors: int = 0
    outliers: int = 0
    examples: tuple[str, ...] = field(default_factory=tuple)

    def describe(self) -> str:
        """One line for the operator."""
        text = (
            f"{self.segments} segment{'s' if self.segments != 1 else ''} "
            f"({self.gaps} gap{'s' if self.gaps != 1 else ''}, "
            f"{self.jumps} time jump{'s' if self.jumps != 1 else ''})"
        )
        if self.anchors:
            text += f", {self.anchors} clock anchor{'s' if self.anchors != 1 else ''}"
        text += f", {self.outliers} outlier{'s' if self.outliers != 1 else ''} left out"
        if self.examples:
            text += f" (first: {self.examples[0]})"
        return text

    def as_dict(self) -> dict:
        return {
            "rows": self.rows,
            "segments": self.segments,
            "gaps": self.gaps,
            "jumps": self.jumps,
            "anchors": self.anchors,
            "outliers": self.outliers,
            "examples": list(self.examples),
        }


def _span(seconds: float) -> str:
    """A signed time difference for a message: seconds, or days where it is that large."""
    if abs(seconds) >= 86400:
        return f"{seconds / 86400:+.1f} days"
    return f"{seconds:+.1f} s"


def _step_s(t: np.ndarray) -> float:
    """The log's nominal step: the median of its positive steps (0 for fewer than two rows)."""
    d = np.diff(t)
    d = d[d > 0]
    return float(np.median(d)) if d.size else 0.0


def _breaks(t: np.ndarray, step: float) -> np.ndarray:
    """Indices i where a new segment starts (row i follows a step that is not the log's own)."""
    if t.size < 2:
        return np.zeros(0, int)
    d = np.diff(t)
    limit = 1.5 * step if step > 0 else 0.0
    return np.flatnonzero((d <= 0) | (d > limit)) + 1


def _max_overlap(lo: np.ndarray, hi: np.ndarray) -> tuple[float, float, int]:
    """The interval [a, b) covered by the most of the half-open intervals [lo, hi), and how many
    cover it (the first such interval where several tie)."""
    edges = np.concatenate([lo, hi])
    steps = np.concatenate([np.ones(lo.size, int), -np.ones(hi.size, int)])
    # At equal positions an interval's end comes before another's start (half-open).
    order = np.lexsort((steps, edges))
    edges, steps = edges[order], steps[order]
    count = np.cumsum(steps)
    best = int(np.argmax(count))
    return float(edges[best]), float(edges[best + 1]), int(count[best])


@dataclass(frozen=True)
class AnchoredTimes:
    """:func:`anchored_utc`'s answer: each row's UTC (seconds since 1970; NaN for a row whose
    run has no UTC at all), which rows are outliers, and the report."""

    utc_s: np.ndarray
    outlier: np.ndarray
    report: ClockReport


def anchored_utc(
    t_log_s: Sequence[float] | np.ndarray,
    utc_whole_s: Sequence[float] | np.ndarray,
    *,
    where: Sequence[str] | None = None,
    resolution_s: float = 1.0,
    truncated: bool = True,
) -> AnchoredTimes:
    """Each row's UTC from the log's own clock ``t_log_s`` and a coarse UTC (module docstring).

    Args:
        t_log_s: the log's own clock per row, seconds (in file order).
        utc_whole_s: each row's UTC as written, seconds since 1970; NaN where the row has none.
        where: a name per row for the report (e.g. "file.csv:12"); default the row index.
        resolution_s: the step of the written UTC (1 s for whole seconds).
        truncated: the written UTC is truncated (the row's time lies in ``[u, u + resolution)``);
            False: rounded (``[u - resolution / 2, u + resolution / 2)``).
    """
    t = np.asarray(t_log_s, float)
    u = np.asarray(utc_whole_s, float)
    n = t.size
    names = list(where) if where is not None else [f"row {i}" for i in range(n)]
    step = _step_s(t)
    tol = step  # a UTC that changes a row early or late is one step of the log's clock off
    starts = [0, *_breaks(t, step).tolist()]
    bounds = list(zip(starts, [*starts[1:], n], strict=True))
    jumps = sum(1 for s in starts[1:] if t[s] <= t[s - 1])
    timed = np.isfinite(u)
    lo = u - t if truncated else u - t - 0.5 * resolution_s
    hi = lo + resolution_s

    def region(idx: np.ndarray) -> tuple[float, float, int] | None:
        idx = idx[timed[idx]]
        return _max_overlap(lo[idx], hi[idx]) if idx.size else None

    runs = _anchor_runs(bounds, t, timed, step, region)

    utc = np.full(n, np.nan)
    outlier = np.zeros(n, bool)
    examples: list[str] = []
    for run in runs:
        idx = np.concatenate([np.arange(*bounds[j]) for j in run])
        reg = region(idx)
        if reg is None:
            continue
        # The middle of what all agreeing rows allow: the region runs from the latest of their
        # lower bounds to the earliest of their upper bounds, each within one step of the log's
        # clock of the truth (a row close after, and one close before, the instant the written
        # UTC changes), so the middle is within half a step, and unbiased.
        anchor = 0.5 * (reg[0] + reg[1])
        utc[idx] = anchor + t[idx]
        off = timed[idx] & ((lo[idx] - tol > anchor) | (hi[idx] + tol <= anchor))
        outlier[idx[off]] = True
        for i in idx[off]:
            if len(examples) < EXAMPLES:
                miss = lo[i] - anchor if lo[i] > anchor else hi[i] - anchor
                examples.append(
                    f"{names[i]}: its UTC is at least {_span(miss)} off the log's clock"
                )
    report = ClockReport(
        rows=int(timed.sum()),
        segments=len(bounds),
        gaps=len(bounds) - 1 - jumps,
        jumps=jumps,
        anchors=len(runs),
        outliers=int(outlier.sum()),
        examples=tuple(examples),
    )
    return AnchoredTimes(utc, outlier, report)


def _anchor_runs(
    bounds: list[tuple[int, int]],
    t: np.ndarray,
    timed: np.ndarray,
    step: float,
    region: Callable[[np.ndarray], tuple[float, float, int] | None],
) -> list[list[int]]:
    """The runs of segments (``bounds``: each segment's rows [a, b)) that share one anchor, in
    order: a segment long enough to trust on its own starts a run unless its UTC region
    (``region`` of its rows) meets the run's within one step of the log's clock (rows were
    missing, the clock went on); an untrusted segment joins the run before it (the first run,
    if none is before it); with no trusted segment, the whole log is one run."""
    tol = step
    runs: list[list[int]] = []  # segment indices
    pending: list[int] = []  # untrusted segments before the first run
    run_region: tuple[float, float, int] | None = None
    for k, (a, b) in enumerate(bounds):
        idx = np.arange(a, b)
        own = region(idx)
        span = t[b - 1] - t[a] + step
        trusted = (
            own is not None
            and span >= MIN_SEGMENT_S
            and own[2] >= max(MIN_SEGMENT_ROWS, 0.5 * int(timed[idx].sum()))
        )
        if not trusted:
            if runs:
                runs[-1].append(k)
            else:
                pending.append(k)
            continue
        assert own is not None
        if run_region is not None and own[0] < run_region[1] + tol and run_region[0] < own[1] + tol:
            runs[-1].append(k)  # the same clock: rows were missing, the clock went on
        else:
            runs.append([*pending, k] if not runs else [k])
            pending = []
        run_idx = np.concatenate([np.arange(*bounds[j]) for j in runs[-1]])
        run_region = region(run_idx)
    if not runs:  # no segment long enough to trust on its own: the whole log is one run
        runs = [list(range(len(bounds)))]
    elif pending:
        runs[0][:0] = pending
    return runs


def consistent_chain(
    utc_s: Sequence[float] | np.ndarray,
    *,
    where: Sequence[str] | None = None,
    weight: Sequence[float] | np.ndarray | None = None,
    max_gap_s: float = MAX_GAP_S,
) -> tuple[np.ndarray, ClockReport]:
    """Which rows (in file order, each with its own UTC in seconds) lie on the log's clock: a mask
    of the rows kept, and the report (module docstring). ``weight`` (default 1 per row) is what a
    row counts for in the heaviest chain: a receiver's epochs without a fix, whose time is its
    real-time clock's guess, weigh little, so a long run of them cannot outvote the fixes."""
    u = np.asarray(utc_s, float)
    n = u.size
    w = np.ones(n) if weight is None else np.asarray(weight, float)
    names = list(where) if where is not None else [f"row {i}" for i in range(n)]
    if n == 0:
        return np.zeros(0, bool), ClockReport(0, 0)
    step = _step_s(u)
    starts = [0, *_breaks(u, step).tolist()]
    bounds = list(zip(starts, [*starts[1:], n], strict=True))
    jumps = sum(1 for s in starts[1:] if not 0 < u[s] - u[s - 1] <= max_gap_s)
    # The heaviest chain of segments: each begins after the one before it ends, within max_gap.
    size = [float(w[a:b].sum()) for a, b in bounds]
    best = list(size)
    prev = [-1] * len(bounds)
    for j, (a, _) in enumerate(bounds):
        for i in range(j):
            end = u[bounds[i][1] - 1]
            if 0 < u[a] - end <= max_gap_s and best[i] + size[j] > best[j]:
                best[j], prev[j] = best[i] + size[j], i
    keep = np.zeros(n, bool)
    j = int(np.argmax(best))
    while j >= 0:
        keep[bounds[j][0] : bounds[j][1]] = True
        j = prev[j]
    examples = []
    kept_u = u[keep]
    for i in np.flatnonzero(~keep)[:EXAMPLES]:
        near = kept_u[np.argmin(np.abs(kept_u - u[i]))] if kept_u.size else u[i]
        examples.append(f"{names[i]}: its UTC is {_span(u[i] - near)} off the log's clock")
    return keep, ClockReport(
        rows=n,
        segments=len(bounds),
        gaps=len(bounds) - 1 - jumps,
        jumps=jumps,
        outliers=int((~keep).sum()),
        examples=tuple(examples),
    )


def fixes_on_their_clock(
    fixes: list, where: Sequence[str], *, log: object, read: str
) -> tuple[list, ClockReport]:
    """The fixes (each with a UTC, in file order) that lie on the log's clock
    (:func:`consistent_chain`), each with ``t_host_ns`` the log's own time: ns since the first
    kept fix's UTC; and the report.

    Raises:
        ParseError: there is no fix; the message names ``log`` and says what was ``read``
            ("244 GPS messages, 0 with a fix").
    """
    from dataclasses import replace

    from snrmon.drivers.errors import ParseError

    if not fixes:
        raise ParseError(f"{log}: no GPS fix in the log ({read})")
    first = fixes[0].utc
    keep, report = consistent_chain([(f.utc - first).total_seconds() for f in fixes], where=where)
    kept = [f for f, k in zip(fixes, keep, strict=True) if k]
    t0 = kept[0].utc
    return [replace(f, t_host_ns=round((f.utc - t0).total_seconds() * 1e9)) for f in kept], report
