"""A PX4 ULog (``.ulg``, the autopilot's own log) as GpsFix lists, for importing a drone's own
flight log into a session (``snrmon gps-import``).

pyulog reads the file (the ``flightlogs`` extra). The fixes are the ``vehicle_gps_position``
topic (the receiver PX4 selected or blended; ``sensor_gps``, the raw receiver, where the log has
no such topic), instance 0. Fields by PX4's message definitions, older and newer: ``lat``/``lon``
in 1e-7 deg and ``alt`` MSL in mm (PX4 before 1.15), or ``latitude_deg``/``longitude_deg`` and
``altitude_msl_m``; ``fix_type`` (0-1 none, 2 2D, 3 3D, 4 DGPS, 5 RTK float, 6 RTK fixed),
``satellites_used``, ``hdop``. Their UTC is the receiver's ``time_utc_usec``; a message without
a fix (``fix_type`` below 2) or without a UTC (0) is counted and dropped, so the rows before the
first lock are never placed at 0 N 0 E. ``t_host_ns`` is the log's own time: ns since its first
fix's UTC.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from snrmon.drivers.errors import MissingDependencyError, ParseError
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.log_clock import ClockReport, fixes_on_their_clock

MAGIC = b"ULog\x01\x12\x35"  # the file header's magic (PX4 ULog file format)
TOPICS = ("vehicle_gps_position", "sensor_gps")
# PX4 fix_type -> GGA fix quality
FIX_TYPE_TO_QUALITY = {2: 1, 3: 1, 4: 2, 5: 5, 6: 4}


@dataclass
class UlogLog:
    fixes: list[GpsFix]
    topic: str
    clock: ClockReport | None = None
    no_fix: int = 0  # messages without a fix or a UTC: dropped


def pyulog():
    """pyulog's ``ULog`` class, or a clear error naming what to install."""
    try:
        return importlib.import_module("pyulog").ULog
    except ImportError:
        raise MissingDependencyError(
            "a PX4 ULog needs pyulog: pip install 'snrmon[flightlogs]'"
        ) from None


def _column(data: dict, new: str, old: str, scale: float) -> np.ndarray | None:
    if new in data:
        return np.asarray(data[new], float)
    if old in data:
        return np.asarray(data[old], float) * scale
    return None


def read_ulog(path: str | Path) -> UlogLog:
    """Every GPS fix of a ``.ulg`` (module docstring).

    Raises:
        FileNotFoundError: no such file.
        ParseError: not a ULog, no GPS topic, or no message with a fix and a UTC.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"ULog {p} not found")
    with p.open("rb") as fh:
        if fh.read(len(MAGIC)) != MAGIC:
            raise ParseError(f"{p}: not a PX4 ULog (no ULog header)")
    try:
        log = pyulog()(str(p), list(TOPICS))
    except (ValueError, OSError, IndexError, KeyError) as exc:  # pyulog on a damaged file
        raise ParseError(f"{p}: pyulog cannot read it: {exc}") from None
    by_name = {(d.name, d.multi_id): d for d in log.data_list}
    topic = next((t for t in TOPICS if (t, 0) in by_name), None)
    if topic is None:
        raise ParseError(f"{p}: no {' or '.join(TOPICS)} topic in the log")
    data = by_name[(topic, 0)].data
    lat = _column(data, "latitude_deg", "lat", 1e-7)
    lon = _column(data, "longitude_deg", "lon", 1e-7)
    alt = _column(data, "altitude_msl_m", "alt", 1e-3)
    if lat is None or lon is None:
        raise ParseError(f"{p}: {topic} has no latitude/longitude fields")
    fix_type = np.asarray(data["fix_type"], int)
    utc_us = np.asarray(data["time_utc_usec"], np.int64)
    ok = (fix_type >= 2) & (utc_us > 0)
    out = UlogLog([], topic, no_fix=int((~ok).sum()))
    sats = data.get("satellites_used")
    hdop = data.get("hdop")
    where = []
    for i in np.flatnonzero(ok):
        us = int(utc_us[i])
        utc = datetime.fromtimestamp(us // 10**6, UTC).replace(microsecond=us % 10**6)
        out.fixes.append(
            GpsFix(
                t_host_ns=0,
                utc=utc,
                lat_deg=float(lat[i]),
                lon_deg=float(lon[i]),
                alt_msl_m=None if alt is None else float(alt[i]),
                fix_quality=FIX_TYPE_TO_QUALITY.get(int(fix_type[i]), 1),
                sats=None if sats is None else int(sats[i]),
                hdop=None if hdop is None else float(hdop[i]),
                raw=f"{topic}[{i}]",
            )
        )
        where.append(f"{p}: {topic} message {i}")
    read = f"{len(fix_type)} {topic} messages, none with fix_type 2 or more and a UTC time"
    out.fixes, out.clock = fixes_on_their_clock(out.fixes, where, log=p, read=read)
    return out
