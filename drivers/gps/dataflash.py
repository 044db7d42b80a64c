"""An ArduPilot DataFlash log (``.BIN``, the autopilot's own log on its SD card) as GpsFix lists,
for importing a drone's own flight log into a session (``snrmon gps-import``).

pymavlink's ``DFReader`` reads the file (the ``mavlink`` extra). The fixes are the receiver's
``GPS`` messages (instance 0, the primary receiver): ``Lat``/``Lng`` in degrees (stored as
1e-7 deg), ``Alt`` MSL in metres (stored in cm), ``Status`` (ArduPilot's GPS_Status: 0 no GPS,
1 no fix, 2 2D, 3 3D, 4 DGPS, 5 RTK float, 6 RTK fixed), ``NSats`` and ``HDop``. Their UTC is the
receiver's own GPS time, ``GWk`` (week since 1980-01-06) and ``GMS`` (ms of the week), less the
leap seconds GPS time does not have: the fix's own time to the millisecond, not the autopilot's
boot clock. A message with ``Status`` below 2 (no fix) or ``GWk`` 0 (no GPS time yet) has no
usable position or time and is counted and dropped, so the rows before the first lock are never
placed at 0 N 0 E. ``t_host_ns`` of a fix is the log's own time: ns since its first fix's UTC.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from pathlib import Path

from snrmon.drivers.errors import MissingDependencyError, ParseError
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.log_clock import ClockReport, fixes_on_their_clock

MAGIC = b"\xa3\x95\x80"  # every DataFlash log starts with its FMT message (header A3 95, id 128)
GPS_EPOCH = datetime(1980, 1, 6, tzinfo=UTC)
# GPS time minus UTC from each date on (IERS bulletins C; none announced after 2017).
LEAP_SECONDS = (
    (datetime(1999, 1, 1, tzinfo=UTC), 13),
    (datetime(2006, 1, 1, tzinfo=UTC), 14),
    (datetime(2009, 1, 1, tzinfo=UTC), 15),
    (datetime(2012, 7, 1, tzinfo=UTC), 16),
    (datetime(2015, 7, 1, tzinfo=UTC), 17),
    (datetime(2017, 1, 1, tzinfo=UTC), 18),
)
# ArduPilot GPS_Status -> GGA fix quality (2D and 3D are a GPS fix; DGPS; RTK float / fixed)
STATUS_TO_QUALITY = {2: 1, 3: 1, 4: 2, 5: 5, 6: 4}


@dataclass
class DataflashLog:
    fixes: list[GpsFix]
    clock: ClockReport | None = None
    no_fix: int = 0  # GPS messages without a fix or without GPS time: dropped
    counts: dict[str, int] = field(default_factory=dict)


def gps_time_to_utc(week: int, ms_of_week: float) -> datetime:
    """UTC of a GPS week and millisecond of the week (leap seconds subtracted)."""
    gps = GPS_EPOCH + timedelta(weeks=week, milliseconds=ms_of_week)
    leap = 0
    for since, seconds in LEAP_SECONDS:
        if gps - timedelta(seconds=seconds) >= since:
            leap = seconds
    return gps - timedelta(seconds=leap)


def dfreader():
    """pymavlink's ``DFReader`` module, or a clear error naming what to install."""
    try:
        return importlib.import_module("pymavlink.DFReader")
    except ImportError:
        raise MissingDependencyError(
            "an ArduPilot DataFlash log needs pymavlink: pip install 'snrmon[mavlink]'"
        ) from None


def read_dataflash(path: str | Path) -> DataflashLog:
    """Every GPS fix of the primary receiver in a DataFlash ``.BIN`` (module docstring).

    Raises:
        FileNotFoundError: no such file.
        ParseError: not a DataFlash log, or no GPS message with a fix in it.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"DataFlash log {p} not found")
    with p.open("rb") as fh:
        if fh.read(3) != MAGIC:
            raise ParseError(f"{p}: not an ArduPilot DataFlash log (no FMT header)")
    reader = dfreader().DFReader_binary(str(p))
    out = DataflashLog([])
    where: list[str] = []
    try:
        while True:
            m = reader.recv_match(type=["GPS"])
            if m is None:
                break
            out.counts["GPS"] = out.counts.get("GPS", 0) + 1
            if getattr(m, "I", 0) != 0:  # a second receiver: the primary one is the log's
                continue
            if m.Status < 2 or m.GWk == 0:
                out.no_fix += 1
                continue
            utc = gps_time_to_utc(int(m.GWk), float(m.GMS))
            out.fixes.append(
                GpsFix(
                    t_host_ns=0,
                    utc=utc,
                    lat_deg=float(m.Lat),
                    lon_deg=float(m.Lng),
                    alt_msl_m=float(m.Alt),
                    fix_quality=STATUS_TO_QUALITY.get(int(m.Status), 1),
                    sats=int(m.NSats),
                    hdop=float(m.HDop),
                    raw=str(m)[:500],
                )
            )
            where.append(f"{p}: GPS at boot time {m.TimeUS / 1e6:.3f} s")
    finally:
        reader.close()
    read = f"{out.counts.get('GPS', 0)} GPS messages, {out.no_fix} without a fix or GPS time"
    out.fixes, out.clock = fixes_on_their_clock(out.fixes, where, log=p, read=read)
    return out
