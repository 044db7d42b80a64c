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
each position. ``t_host_ns`` of a fix is the log's own time: ns since its first fix's UTC.
Resolution: 1e-7 deg (about 1 cm) and 1 mm.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.mavlink import FIX_TYPE_TO_QUALITY, mavutil

UNIX_USEC_2001 = 978_307_200_000_000  # a time_usec below this is time since boot, not UTC


@dataclass
class TlogLog:
    fixes: list[GpsFix]
    utc_source: str
    counts: dict[str, int] = field(default_factory=dict)


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
    conn = mavutil().mavlink_connection(str(p))
    system_time: list[tuple[int, int]] = []  # (time_boot_ms, time_unix_usec)
    gpi: list[tuple[float, object]] = []  # (receipt s, msg)
    raw: list[tuple[float, object]] = []
    counts: dict[str, int] = {}
    try:
        while True:
            msg = conn.recv_match(
                type=["GLOBAL_POSITION_INT", "GPS_RAW_INT", "SYSTEM_TIME"], blocking=False
            )
            if msg is None:
                break
            kind = msg.get_type()
            counts[kind] = counts.get(kind, 0) + 1
            if kind == "SYSTEM_TIME":
                if msg.time_unix_usec > UNIX_USEC_2001:
                    system_time.append((int(msg.time_boot_ms), int(msg.time_unix_usec)))
            elif kind == "GLOBAL_POSITION_INT":
                gpi.append((float(msg._timestamp), msg))
            else:
                raw.append((float(msg._timestamp), msg))
    finally:
        conn.close()
    raw_t = [t for t, _ in raw]

    def with_raw(fix: GpsFix, t_receipt: float) -> GpsFix:
        i = bisect.bisect_right(raw_t, t_receipt) - 1
        if i < 0:
            return fix
        r = raw[i][1]
        return replace(
            fix,
            fix_quality=FIX_TYPE_TO_QUALITY.get(r.fix_type, 1),
            sats=None if r.satellites_visible == 255 else int(r.satellites_visible),
            hdop=None if r.eph == 65535 else r.eph / 100.0,
        )

    fixes: list[GpsFix] = []
    if gpi and system_time:
        source = "system_time"
        boots = [b for b, _ in system_time]
        for t, m in gpi:
            # The SYSTEM_TIME nearest in boot time: the autopilot's clock drifts from UTC.
            i = bisect.bisect_left(boots, m.time_boot_ms)
            near = min(
                (j for j in (i - 1, i) if 0 <= j < len(boots)),
                key=lambda j: abs(boots[j] - m.time_boot_ms),
            )
            b, unix = system_time[near]
            utc = _utc(unix + (m.time_boot_ms - b) * 1000)
            fixes.append(with_raw(_position(m, utc, m.alt), t))
    elif any(m.time_usec > UNIX_USEC_2001 and m.fix_type >= 2 for _, m in raw):
        source = "gps_raw_int"
        for _, m in raw:
            if m.time_usec > UNIX_USEC_2001 and m.fix_type >= 2:
                fix = _position(m, _utc(m.time_usec), m.alt)
                fixes.append(
                    replace(
                        fix,
                        fix_quality=FIX_TYPE_TO_QUALITY.get(m.fix_type, 1),
                        sats=None if m.satellites_visible == 255 else int(m.satellites_visible),
                        hdop=None if m.eph == 65535 else m.eph / 100.0,
                    )
                )
    elif gpi:
        source = "tlog_receipt"
        fixes = [with_raw(_position(m, _utc(t * 1e6), m.alt), t) for t, m in gpi]
    else:
        raise ParseError(f"{p}: no GLOBAL_POSITION_INT or GPS_RAW_INT message in the log")
    fixes.sort(key=lambda f: f.utc)
    first = fixes[0].utc
    fixes = [replace(f, t_host_ns=round((f.utc - first).total_seconds() * 1e9)) for f in fixes]
    return TlogLog(fixes, source, counts)


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
