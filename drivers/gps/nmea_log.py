"""A receiver's NMEA 0183 log file (one sentence a line, as ``gpspipe -r`` or a logger writes
it) as one :class:`GpsFix` per epoch, for importing a drone's or a receiver's own log into a
session (``snrmon gps-import --nmea``).

The lines go through the same :class:`snrmon.drivers.gps.nmea.NmeaAssembler` as a live receiver.
An epoch's GGA and RMC (same UTC) are merged into one fix, each field taken from whichever
sentence carries it (GGA: altitude, quality, satellites, HDOP; RMC: the date). Lines starting
with ``#`` and blank lines are skipped (gpsd's regression logs carry comments); a line that does
not decode is counted and skipped, because a logger's file often holds a torn line where it was
stopped. A fix before the receiver gave a date has no UTC and cannot be placed on a session's
clock: it is counted in ``without_utc`` and left out.

The log's time is its epochs in file order: gaps (the logger paused), time jumps (a receiver
reports its real-time clock's guess, 1980 or a week off, until it has the almanac, then jumps to
the true time) and midnight (the assembler carries the date over) are taken as
:func:`snrmon.drivers.gps.log_clock.consistent_chain` does: the chain of consistent segments with
the most fixes is the log's clock; epochs off it are counted and named in ``clock`` and left out,
so one wrong epoch never reorders or moves the others. ``t_host_ns`` of each fix is the log's
own time: ns since its first kept epoch's UTC.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field, replace
from pathlib import Path

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.log_clock import ClockReport, consistent_chain
from snrmon.drivers.gps.nmea import NmeaAssembler

NO_FIX_WEIGHT = 1e-3  # an epoch without a fix, in the choice of the log's clock


@dataclass
class NmeaLog:
    """The fixes of a log, one per epoch in UTC order, and what was skipped."""

    fixes: list[GpsFix]
    clock: ClockReport | None = None
    lines: int = 0
    bad_lines: int = 0
    without_utc: int = 0
    first_error: str | None = None
    by_address: dict[str, int] = field(default_factory=dict)
    lines_moved: int = 0  # epochs moved to sort an out-of-order log by its UTC (0: in order)
    off_clock: int = 0  # epochs with a fix left out because their time is off the log's clock


def _chain(epochs: list[tuple[GpsFix, int]], p: Path) -> tuple[list[bool], ClockReport]:
    """Which epochs lie on the log's clock, in the order given (consistent_chain)."""
    utc = [f.utc for f, _ in epochs]
    first_utc = min(u for u in utc if u is not None)
    keep, clock = consistent_chain(
        [(u - first_utc).total_seconds() for u in utc],  # type: ignore[operator]
        where=[f"{p}:{line} ({f.utc:%Y-%m-%d %H:%M:%S})" for f, line in epochs],
        weight=[1.0 if f.has_fix else NO_FIX_WEIGHT for f, _ in epochs],
    )
    return [bool(k) for k in keep], clock


def _longest_increasing_run(values: list[int]) -> int:
    """The length of the longest increasing subsequence: the lines that can stay where they
    are when the rest are moved (patience sorting, O(n log n))."""
    tails: list[int] = []
    for v in values:
        i = bisect.bisect_left(tails, v)
        tails[i : i + 1] = [v]
    return len(tails)


def _merge(a: GpsFix, b: GpsFix) -> GpsFix:
    """One epoch's fix from two sentences: b's fields where a has none."""

    def pick(x, y):
        return x if x is not None else y

    return replace(
        a,
        lat_deg=pick(a.lat_deg, b.lat_deg),
        lon_deg=pick(a.lon_deg, b.lon_deg),
        alt_msl_m=pick(a.alt_msl_m, b.alt_msl_m),
        alt_ellipsoid_m=pick(a.alt_ellipsoid_m, b.alt_ellipsoid_m),
        fix_quality=max(a.fix_quality, b.fix_quality) if a.fix_quality and b.fix_quality else 0,
        sats=pick(a.sats, b.sats),
        hdop=pick(a.hdop, b.hdop),
        raw=f"{a.raw} {b.raw}",
    )


def read_nmea_log(path: str | Path) -> NmeaLog:
    """Every epoch with a UTC time in the log at ``path``.

    Raises:
        FileNotFoundError: no such file.
        ParseError: the file holds no fix with a UTC time (the message names the file and the
            first undecodable line, if any).
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"NMEA log {p} not found")
    # Checksum-less sentences are accepted: some loggers strip them; a torn line still fails
    # its field decoding and is counted as bad.
    asm = NmeaAssembler(allow_no_checksum=True)
    out = NmeaLog([])
    epochs: list[tuple[GpsFix, int]] = []  # one per epoch in file order, with its line
    for lineno, raw in enumerate(p.read_bytes().splitlines(), start=1):
        if not raw.strip() or raw.startswith(b"#"):
            continue
        out.lines += 1
        try:
            fixes = asm.feed(raw.strip(), 0)
        except ParseError as exc:
            out.bad_lines += 1
            out.first_error = out.first_error or f"{p}:{lineno}: {exc}"
            continue
        for f in fixes:
            if f.utc is None:
                out.without_utc += 1
            elif epochs and epochs[-1][0].utc == f.utc:
                # RMC and GGA of one epoch: an invalid RMC (quality 0) voids the pair.
                epochs[-1] = (_merge(epochs[-1][0], f), epochs[-1][1])
            else:
                epochs.append((f, lineno))
    out.by_address = dict(asm.counts.by_address)
    if not epochs:
        why = f" (first bad line: {out.first_error})" if out.first_error else ""
        raise ParseError(f"{p}: no NMEA fix with a UTC date and time in {out.lines} lines{why}")
    keep, out.clock = _chain(epochs, p)
    # A log whose lines were reordered (reversed, shuffled by a tool that sorted on another
    # field) is not a clock that jumped: when file order keeps fewer than half of the fixes,
    # the epochs are sorted by their own UTC, and the lines that had to move are counted.
    fixed = sum(f.has_fix for f, _ in epochs)
    if sum(f.has_fix for (f, _), k in zip(epochs, keep, strict=True) if k) < 0.5 * fixed:
        ordered: list[tuple[GpsFix, int]] = []
        for f, line in sorted(epochs, key=lambda e: e[0].utc):  # type: ignore[arg-type,return-value]
            if ordered and ordered[-1][0].utc == f.utc:  # one epoch's GGA and RMC, apart
                ordered[-1] = (_merge(ordered[-1][0], f), min(ordered[-1][1], line))
            else:
                ordered.append((f, line))
        keep_sorted, clock_sorted = _chain(ordered, p)
        if sum(keep_sorted) > sum(keep):
            out.lines_moved = len(ordered) - _longest_increasing_run([ln for _, ln in ordered])
            epochs, keep, out.clock = ordered, keep_sorted, clock_sorted
    kept = [f for (f, _), k in zip(epochs, keep, strict=True) if k]
    out.off_clock = sum(f.has_fix for (f, _), k in zip(epochs, keep, strict=True) if not k)
    first = kept[0].utc
    assert first is not None
    out.fixes = [
        replace(f, t_host_ns=round((f.utc - first).total_seconds() * 1e9))  # type: ignore[operator]
        for f in kept
    ]
    return out
