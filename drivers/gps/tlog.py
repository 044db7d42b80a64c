"""A MAVLink telemetry log (``.tlog``, as QGroundControl and MAVProxy write it) as GpsFix lists,
for importing a drone's own flight log into a session (``snrmon gps-import --tlog``).

A ``.tlog`` is each received MAVLink packet preceded by the ground station's receipt time (8-byte
big-endian microseconds since 1970); pymavlink's ``mavutil`` reads it (MAVLink 1 and 2).
Positions and their UTC, best first:

1. ``GLOBAL_POSITION_INT`` (lat/lon degE7, ``alt`` MSL in mm; the autopilot's fused position)
   stamped ``time_boot_ms``, mapped to UTC through the nearest ``SYSTEM_TIME`` (which pairs
   ``time_unix_usec`` with ``time_boot_ms``) -> ``utc_source = "system_time"``;
2. without a usable ``SYSTEM_TIME``: the receiver's own ``GPS_RAW_INT`` positions, whose
   ``time_usec`` is UTC when the autopilot has GPS time (a value past 2001; otherwise it is time
   since boot and unusable) -> ``"gps_raw_int"``;
3. otherwise ``GLOBAL_POSITION_INT`` at the ground station's receipt time -> ``"tlog_receipt"``
   (as good as that computer's clock, plus the link's latency).

Fix type, satellites and HDOP (``eph`` / 100) come from the latest ``GPS_RAW_INT`` at or before
each position. Only fixes are kept: a position before the log's first ``GPS_RAW_INT`` (nothing
says it is a fix: the autopilot reports its origin, 0 N 0 E, until the receiver locks), one
whose ``GPS_RAW_INT`` has ``fix_type`` below 2, or one at 0 N 0 E, is counted in ``no_fix`` and
dropped; a log without a fix is refused. (A log with no ``GPS_RAW_INT`` at all takes its
positions as fixes.) The ground station's receipt time minus each fix's UTC is measured
(``clock_offset_s``, the median, and its spread): a link's latency is tens of ms, so an offset
beyond ``CLOCK_OFFSET_WARN_S`` says one of the two clocks is wrong.
``t_host_ns`` of a fix is the log's own time: ns since its first fix's UTC.
Resolution: 1e-7 deg (about 1 cm) and 1 mm.

Logs as they are: an autopilot that reboots starts ``time_boot_ms`` again, so the log is cut into
boots where the boot time goes back, and a position is mapped only through a ``SYSTEM_TIME`` of
its own boot; within a boot, a ``SYSTEM_TIME`` whose UTC disagrees with the boot's others (more
than ``SYSTEM_TIME_TOLERANCE_S`` off their median pairing: a clock set late, a bad GPS time) is
counted and left out. The link's dropouts are gaps; the fixes' UTC in file order then goes
through :func:`snrmon.drivers.gps.log_clock.consistent_chain`, so a fix whose time jumps is
counted, named in ``clock`` and left out rather than moving or reordering the others.
"""

from __future__ import annotations

import bisect
import statistics
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.log_clock import ClockReport, consistent_chain
from snrmon.drivers.gps.mavlink import FIX_TYPE_TO_QUALITY, mavutil

UNIX_USEC_2001 = 978_307_200_000_000  # a time_usec below this is time since boot, not UTC
REBOOT_MS = 1000  # time_boot_ms going back by more than this: the autopilot restarted
SYSTEM_TIME_TOLERANCE_S = 1.0
CLOCK_OFFSET_WARN_S = 1.0  # a link's latency is tens of ms; beyond this a clock is off


@dataclass
class TlogLog:
    fixes: list[GpsFix]
    utc_source: str
    counts: dict[str, int] = field(default_factory=dict)
    clock: ClockReport | None = None
    boots: int = 1
    no_fix: int = 0  # positions without a fix (before the first GPS_RAW_INT with one): dropped
    off_clock: int = 0  # fixes left out because their time is off the log's clock
    clock_offset_s: float | None = None  # median receipt time - the fix's UTC (None: receipt)
    clock_offset_spread_s: float | None = None  # its 5..95 % range

    def describe_clock_offset(self) -> str:
        """One line: the ground station's receipt time against the autopilot's UTC."""
        off = self.clock_offset_s
        if off is None:
            return "positions on the ground station's receipt time (the autopilot gave no UTC)"
        line = (
            f"the autopilot's clock against the ground station's receipt time: received "
            f"{off:+.3f} s after the fix's UTC (median; 5-95 % spread "
            f"{self.clock_offset_spread_s:.3f} s)"
        )
        if abs(off) > CLOCK_OFFSET_WARN_S:
            line += (
                f"; more than {CLOCK_OFFSET_WARN_S:g} s: one of the two clocks is wrong (the "
                "fixes keep the autopilot's UTC)"
            )
        return line


def _utc(usec: float) -> datetime:
    return datetime.fromtimestamp(usec / 1e6, tz=UTC)


def read_tlog(path: str | Path) -> TlogLog:
    """The positions of a ``.tlog`` (see the module docstring for the UTC sources).

    Raises:
        FileNotFoundError: no such file.
        ParseError: no position message in the file.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"MAVLink log {p} not found")
    msgs = _tlog_messages(p)
    pairings, set_aside = _consistent_system_times(msgs.system_time, p)
    source, timed = _timed_positions(msgs, pairings, set_aside, p)
    if not timed.fixes:
        raise ParseError(f"{p}: no position with a UTC time ({set_aside[0]})")
    # Only fixes: a position before the receiver's first fix is the autopilot's origin
    # (0 N 0 E, or the home it was given), not a place the drone was.
    has = [f.has_fix and (f.lat_deg, f.lon_deg) != (0.0, 0.0) for f in timed.fixes]
    no_fix = len(timed.fixes) - sum(has)
    if not any(has):
        raise ParseError(
            f"{p}: no GPS fix in the log: {len(timed.fixes)} positions, none while GPS_RAW_INT "
            "reported a fix (fix_type 2 or more)"
        )
    fixes = [f for f, h in zip(timed.fixes, has, strict=True) if h]
    where = [w for w, h in zip(timed.where, has, strict=True) if h]
    receipts = [r for r, h in zip(timed.receipts, has, strict=True) if h]
    first_utc = fixes[0].utc
    keep, report = consistent_chain(
        [(f.utc - first_utc).total_seconds() for f in fixes],  # type: ignore[operator]
        where=where,
    )
    lag = [r - f.utc.timestamp() for f, r, k in zip(fixes, receipts, keep, strict=True) if k]  # type: ignore[union-attr]
    fixes = [f for f, k in zip(fixes, keep, strict=True) if k]
    report = replace(
        report,
        outliers=report.outliers + len(set_aside),
        examples=(*set_aside, *report.examples)[:5],
    )
    first = fixes[0].utc
    fixes = [replace(f, t_host_ns=round((f.utc - first).total_seconds() * 1e9)) for f in fixes]
    out = TlogLog(
        fixes,
        source,
        msgs.counts,
        report,
        msgs.boot + 1,
        no_fix=no_fix,
        off_clock=int(len(keep) - sum(keep)),
    )
    if source != "tlog_receipt":
        q = np.percentile(lag, [5, 50, 95])
        out.clock_offset_s, out.clock_offset_spread_s = float(q[1]), float(q[2] - q[0])
    return out


@dataclass
class _TlogMessages:
    """The messages of a log that hold positions and time, in file order."""

    # (boot, time_boot_ms, time_unix_usec, file position) of every SYSTEM_TIME with a UTC
    system_time: list[tuple[int, int, int, int]] = field(default_factory=list)
    gpi: list[tuple[float, int, Any]] = field(default_factory=list)  # (receipt s, boot, msg)
    raw: list[tuple[float, Any]] = field(default_factory=list)  # (receipt s, GPS_RAW_INT)
    counts: dict[str, int] = field(default_factory=dict)
    boot: int = 0  # the last boot's index (0: the autopilot never restarted)


def _tlog_messages(p: Path) -> _TlogMessages:
    """SYSTEM_TIME, GLOBAL_POSITION_INT and GPS_RAW_INT of the log at ``p``, each position and
    SYSTEM_TIME with the boot it belongs to, and the count of each type."""
    conn = mavutil().mavlink_connection(str(p))
    out = _TlogMessages()
    last_boot_ms = None
    try:
        while True:
            msg = conn.recv_match(
                type=["GLOBAL_POSITION_INT", "GPS_RAW_INT", "SYSTEM_TIME"], blocking=False
            )
            if msg is None:
                break
            kind = msg.get_type()
            out.counts[kind] = out.counts.get(kind, 0) + 1
            if kind in ("SYSTEM_TIME", "GLOBAL_POSITION_INT"):
                if last_boot_ms is not None and msg.time_boot_ms < last_boot_ms - REBOOT_MS:
                    out.boot += 1
                last_boot_ms = int(msg.time_boot_ms)
            if kind == "SYSTEM_TIME":
                if msg.time_unix_usec > UNIX_USEC_2001:
                    n = sum(out.counts.values())
                    out.system_time.append(
                        (out.boot, int(msg.time_boot_ms), int(msg.time_unix_usec), n)
                    )
            elif kind == "GLOBAL_POSITION_INT":
                out.gpi.append((float(msg._timestamp), out.boot, msg))
            else:
                out.raw.append((float(msg._timestamp), msg))
    finally:
        conn.close()
    return out


@dataclass
class _TimedPositions:
    """Positions with their UTC, each with where in the log it is and its receipt time (s since
    1970 by the ground station's clock)."""

    fixes: list[GpsFix] = field(default_factory=list)
    where: list[str] = field(default_factory=list)
    receipts: list[float] = field(default_factory=list)

    def add(self, fix: GpsFix, where: str, t_receipt: float) -> None:
        self.fixes.append(fix)
        self.where.append(where)
        self.receipts.append(t_receipt)


def _timed_positions(
    msgs: _TlogMessages,
    pairings: dict[int, list[tuple[int, int]]],
    set_aside: list[str],
    p: Path,
) -> tuple[str, _TimedPositions]:
    """(utc_source, positions) from the best UTC source the log holds (the module docstring's
    order); a position of a boot without a usable SYSTEM_TIME is named in ``set_aside``."""
    gpi, raw = msgs.gpi, msgs.raw
    if gpi and any(pairings.get(b) for _, b, _ in gpi):
        return "system_time", _system_time_positions(msgs, pairings, set_aside, p)
    out = _TimedPositions()
    if any(m.time_usec > UNIX_USEC_2001 and m.fix_type >= 2 for _, m in raw):
        for t, m in raw:
            if m.time_usec > UNIX_USEC_2001 and m.fix_type >= 2:
                fix = _with_receiver_status(_position(m, _utc(m.time_usec), m.alt), m)
                out.add(fix, f"{p}: GPS_RAW_INT received at {_utc(t * 1e6):%H:%M:%S.%f}", t)
        return "gps_raw_int", out
    if gpi:
        for t, _, m in gpi:
            fix = _with_raw(_position(m, _utc(t * 1e6), m.alt), t, raw)
            out.add(fix, f"{p}: position received at {_utc(t * 1e6):%H:%M:%S.%f}", t)
        return "tlog_receipt", out
    raise ParseError(f"{p}: no GLOBAL_POSITION_INT or GPS_RAW_INT message in the log")


def _system_time_positions(
    msgs: _TlogMessages,
    pairings: dict[int, list[tuple[int, int]]],
    set_aside: list[str],
    p: Path,
) -> _TimedPositions:
    """Each GLOBAL_POSITION_INT at the UTC of its boot's SYSTEM_TIME nearest in boot time (the
    autopilot's clock drifts from UTC); one of a boot without any is named in ``set_aside``."""
    out = _TimedPositions()
    for t, b, m in msgs.gpi:
        pairs = pairings.get(b)
        if not pairs:  # a boot without a usable SYSTEM_TIME: its positions have no UTC
            set_aside.append(f"{p}: a position of boot {b + 1} without a SYSTEM_TIME")
            continue
        boots = [bt for bt, _ in pairs]
        i = bisect.bisect_left(boots, m.time_boot_ms)
        near = min(
            (j for j in (i - 1, i) if 0 <= j < len(boots)),
            key=lambda j: abs(boots[j] - m.time_boot_ms),
        )
        bt, unix = pairs[near]
        utc = _utc(unix + (m.time_boot_ms - bt) * 1000)
        fix = _with_raw(_position(m, utc, m.alt), t, msgs.raw)
        out.add(fix, f"{p}: position at boot {b + 1} time {m.time_boot_ms / 1000:.3f} s", t)
    return out


def _with_raw(fix: GpsFix, t_receipt: float, raw: list[tuple[float, Any]]) -> GpsFix:
    """``fix`` with the status of the latest GPS_RAW_INT received at or before ``t_receipt``."""
    i = bisect.bisect_right(raw, t_receipt, key=lambda r: r[0]) - 1
    if i < 0:
        # Before the first GPS_RAW_INT nothing says the position is a fix (it is the
        # autopilot's origin until the receiver locks); in a log without any, a position
        # away from 0 N 0 E is taken as one (the link was set up without GPS_RAW_INT).
        return replace(fix, fix_quality=0) if raw else fix
    return _with_receiver_status(fix, raw[i][1])


def _with_receiver_status(fix: GpsFix, r) -> GpsFix:
    """``fix`` with the fix type, satellites and HDOP of the GPS_RAW_INT ``r``."""
    return replace(
        fix,
        fix_quality=FIX_TYPE_TO_QUALITY.get(r.fix_type, 1),
        sats=None if r.satellites_visible == 255 else int(r.satellites_visible),
        hdop=None if r.eph == 65535 else r.eph / 100.0,
    )


def _consistent_system_times(
    system_time: list[tuple[int, int, int, int]], path: Path
) -> tuple[dict[int, list[tuple[int, int]]], list[str]]:
    """Per boot, its SYSTEM_TIME pairings (time_boot_ms, time_unix_usec) sorted by boot time,
    without those more than ``SYSTEM_TIME_TOLERANCE_S`` off the boot's median pairing; and a
    line for each one set aside."""
    by_boot: dict[int, list[tuple[int, int, int]]] = {}
    for b, bt, unix, k in system_time:
        by_boot.setdefault(b, []).append((bt, unix, k))
    out: dict[int, list[tuple[int, int]]] = {}
    aside: list[str] = []
    for b, rows in by_boot.items():
        offset = statistics.median(unix - bt * 1000 for bt, unix, _ in rows)
        good = []
        for bt, unix, k in rows:
            off_s = (unix - bt * 1000 - offset) / 1e6
            if abs(off_s) > SYSTEM_TIME_TOLERANCE_S:
                aside.append(f"{path}: message {k}: SYSTEM_TIME {off_s:+.1f} s off its boot's")
            else:
                good.append((bt, unix))
        out[b] = sorted(good)
    return out, aside


def _position(m, utc: datetime, alt_mm: int) -> GpsFix:
    return GpsFix(
        t_host_ns=0,
        utc=utc,
        lat_deg=m.lat / 1e7,
        lon_deg=m.lon / 1e7,
        alt_msl_m=alt_mm / 1000.0,
        fix_quality=1,
        raw=str(m)[:500],
    )
