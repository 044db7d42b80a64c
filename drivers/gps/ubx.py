"""A u-blox receiver's binary UBX log (as u-center or a logger records it, NMEA possibly
interleaved) as GpsFix lists, for importing it into a session (``snrmon gps-import``).

pyubx2 reads the frames (the ``flightlogs`` extra); the fixes are the ``NAV-PVT`` messages
(u-blox interface description, UBX-NAV-PVT): ``lat``/``lon`` (1e-7 deg), ``hMSL`` (mm, height
above mean sea level) and ``height`` (mm, above the ellipsoid), ``fixType`` (2 2D, 3 3D, 4 GNSS +
dead reckoning), ``gnssFixOK``, ``carrSoln`` (1 RTK float, 2 RTK fixed), ``numSV``, ``pDOP``.
Their UTC is the message's own date and time of day plus ``nano`` (ns, signed), valid only where
``validDate`` and ``validTime`` are set. A message without a valid fix or a valid UTC is counted
and dropped. ``hdop`` is left None: NAV-PVT carries position DOP only (NAV-DOP has HDOP).
``t_host_ns`` is the log's own time: ns since its first fix's UTC.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from pathlib import Path

from snrmon.drivers.errors import MissingDependencyError
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.log_clock import ClockReport, fixes_on_their_clock

SYNC = b"\xb5\x62"
CARRIER_TO_QUALITY = {1: 5, 2: 4}  # carrSoln: RTK float, RTK fixed


@dataclass
class UbxLog:
    fixes: list[GpsFix]
    clock: ClockReport | None = None
    nav_pvt: int = 0  # NAV-PVT messages read
    no_fix: int = 0  # of which without a valid fix or UTC: dropped


def pyubx2():
    """The pyubx2 module, or a clear error naming what to install."""
    try:
        return importlib.import_module("pyubx2")
    except ImportError:
        raise MissingDependencyError(
            "a u-blox UBX log needs pyubx2: pip install 'snrmon[flightlogs]'"
        ) from None


def is_ubx_frame(data: bytes, at: int) -> bool:
    """True when ``data[at:]`` starts a complete UBX frame whose Fletcher checksum matches."""
    if data[at : at + 2] != SYNC or len(data) < at + 8:
        return False
    length = int.from_bytes(data[at + 4 : at + 6], "little")
    end = at + 6 + length
    if len(data) < end + 2:
        return False
    a = b = 0
    for byte in data[at + 2 : end]:
        a = (a + byte) & 0xFF
        b = (b + a) & 0xFF
    return data[end] == a and data[end + 1] == b


def read_ubx(path: str | Path) -> UbxLog:
    """Every NAV-PVT fix of a UBX log (module docstring).

    Raises:
        FileNotFoundError: no such file.
        ParseError: no NAV-PVT message with a fix and a valid UTC.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"UBX log {p} not found")
    ubx = pyubx2()
    out = UbxLog([])
    where = []
    with p.open("rb") as fh:
        # quitonerror=0: a torn frame where the logger stopped is skipped, not fatal
        for _, msg in ubx.UBXReader(fh, protfilter=ubx.UBX_PROTOCOL, quitonerror=0):
            if msg is None or msg.identity != "NAV-PVT":
                continue
            out.nav_pvt += 1
            if not (msg.gnssFixOk and msg.fixType in (2, 3, 4) and msg.validDate and msg.validTime):
                out.no_fix += 1
                continue
            utc = datetime(
                msg.year, msg.month, msg.day, msg.hour, msg.min, msg.second, tzinfo=UTC
            ) + timedelta(microseconds=msg.nano / 1000)
            out.fixes.append(
                GpsFix(
                    t_host_ns=0,
                    utc=utc,
                    lat_deg=float(msg.lat),
                    lon_deg=float(msg.lon),
                    alt_msl_m=msg.hMSL / 1000.0,
                    alt_ellipsoid_m=msg.height / 1000.0,
                    fix_quality=CARRIER_TO_QUALITY.get(msg.carrSoln, 2 if msg.diffSoln else 1),
                    sats=int(msg.numSV),
                    raw=str(msg)[:500],
                )
            )
            where.append(f"{p}: NAV-PVT {out.nav_pvt} (iTOW {msg.iTOW})")
    read = f"{out.nav_pvt} NAV-PVT messages, {out.no_fix} without a valid fix or UTC"
    out.fixes, out.clock = fixes_on_their_clock(out.fixes, where, log=p, read=read)
    return out
