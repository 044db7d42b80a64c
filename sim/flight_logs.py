"""The drone's own flight logs of a simulated flight: a DJI AirData CSV export, a receiver's NMEA
log and a MAVLink ``.tlog``, each in its real format, for testing ``snrmon gps-import``.

Each writer takes :class:`LogEpoch` rows (UTC and position, from :func:`flight_epochs`) and writes
what the real logger would, at the resolution it would:

- AirData CSV: ``time(millisecond)`` from the log's start; AirData's time base, which puts the
  first row with a position on the whole second written in it (the simulated receiver's first
  fix is its first epoch of a second, on the ground before take-off, so the export's time is
  up to one 0.1 s step before the epoch's UTC, as AirData's would be); ``datetime(utc)`` the
  whole second of that time + 0.6 s (the real Air 2S export's seconds lead its GPX by 0.6 s);
  latitude/longitude with 8 decimals, ``altitude_above_seaLevel(feet)`` with 1 decimal
  (3 cm), ``satellites``; rows with 0,0 before the first fix, as DJI writes them;
- NMEA: GGA + RMC per epoch (the simulated receiver's own sentences: centisecond UTC,
  minutes with 7 decimals, altitude in mm);
- tlog: per epoch ``GPS_RAW_INT`` and ``GLOBAL_POSITION_INT`` (degE7, mm) on the autopilot's
  boot clock, a ``SYSTEM_TIME`` once a second pairing boot time with UTC, each packet preceded by
  the ground station's receipt time (``latency_s`` later), MAVLink 2 through pymavlink.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime, timedelta
from pathlib import Path

from snrmon.sim.devices.nmea_sim import gga_rmc
from snrmon.sim.flight import FlightPlan

FEET = 0.3048
AIRDATA_HEADER = (
    "time(millisecond),datetime(utc),latitude,longitude,height_above_takeoff(feet),"
    "altitude_above_seaLevel(feet),satellites,gpslevel,speed(mph),compass_heading(degrees),"
    "isVideo,message"
)


@dataclass(frozen=True)
class LogEpoch:
    utc: datetime
    lat_deg: float
    lon_deg: float
    alt_m: float


def flight_epochs(
    plan: FlightPlan, flight_t_s: Sequence[float], utc: Sequence[datetime]
) -> list[LogEpoch]:
    """The flight's truth at each flight time, labelled with the UTC the logger gives it."""
    out = []
    for t, u in zip(flight_t_s, utc, strict=True):
        lat, lon, alt = plan.position(t)
        out.append(LogEpoch(u, lat, lon, alt))
    return out


def write_airdata_csv(
    path: str | Path, epochs: Sequence[LogEpoch], *, sats: int = 14, no_fix_rows: int = 3
) -> Path:
    """An AirData export of the flight (see the module docstring): ``no_fix_rows`` rows without
    a position, then the drone on the ground at its first epoch's position from the receiver's
    first epoch of a second (up to nine 0.1 s rows before the flight's first epoch, as a DJI
    drone waits for its fix before it takes off), then the flight."""
    out = Path(path)
    start = epochs[0]
    lead = next(m for m in range(10) if (start.utc - timedelta(seconds=0.1 * m)).microsecond < 1e5)
    ground = [(start.utc - timedelta(seconds=0.1 * m), start) for m in range(lead, 0, -1)]
    first_fix = start.utc - timedelta(seconds=0.1 * lead)
    base = timedelta(microseconds=first_fix.microsecond)  # AirData's: the first fix on its second
    t0 = first_fix - timedelta(seconds=0.1 * no_fix_rows)
    home_ft = start.alt_m / FEET
    lines = [AIRDATA_HEADER]
    rows: list[tuple[datetime, LogEpoch | None]] = [
        (t0 + timedelta(seconds=0.1 * k), None) for k in range(no_fix_rows)
    ]
    rows += ground + [(e.utc, e) for e in epochs]
    for u, e in rows:
        ms = round((u - t0).total_seconds() * 1000)
        # whole seconds, 0.6 s ahead of the row's time on AirData's time base
        stamp = (u - base + timedelta(microseconds=600_000)).strftime("%Y-%m-%d %H:%M:%S")
        if e is None:
            lines.append(f"{ms},{stamp},0.0,0.0,0.0,0.0,0,0,0.0,0.0,0,")
            continue
        alt_ft = e.alt_m / FEET
        lines.append(
            f"{ms},{stamp},{e.lat_deg:.8f},{e.lon_deg:.8f},{alt_ft - home_ft:.1f},{alt_ft:.1f},"
            f"{sats},5,0.0,40.0,1,"
        )
    out.write_text("\n".join(lines) + "\n")
    return out


def write_nmea_log(path: str | Path, epochs: Sequence[LogEpoch], *, sats: int = 12) -> Path:
    """The receiver's sentences, GGA then RMC per epoch, with a comment header."""
    out = Path(path)
    with out.open("wb") as fh:
        fh.write(b"# simulated drone receiver log (snrmon sim/flight_logs.py)\n")
        for e in epochs:
            for s in gga_rmc(e.utc, e.lat_deg, e.lon_deg, e.alt_m, sats=sats):
                fh.write(s)
    return out


def write_tlog(
    path: str | Path,
    epochs: Sequence[LogEpoch],
    *,
    boot_utc: datetime | None = None,
    latency_s: float = 0.03,
    sats: int = 15,
) -> Path:
    """A ground station's ``.tlog`` of the autopilot's stream (see the module docstring)."""
    from pymavlink.dialects.v20 import common as mavlink2

    out = Path(path)
    boot = boot_utc or (epochs[0].utc - timedelta(seconds=60))
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    last_system_time_s = None
    with out.open("wb") as fh:

        def put(msg, utc: datetime) -> None:
            receipt_us = round((utc.timestamp() + latency_s) * 1e6)
            fh.write(struct.pack(">Q", receipt_us) + msg.pack(mav))

        for e in epochs:
            unix_us = round(e.utc.timestamp() * 1e6)
            boot_ms = round((e.utc - boot).total_seconds() * 1000)
            if last_system_time_s is None or e.utc.timestamp() - last_system_time_s >= 1.0:
                put(mavlink2.MAVLink_system_time_message(unix_us, boot_ms), e.utc)
                last_system_time_s = e.utc.timestamp()
            lat, lon = round(e.lat_deg * 1e7), round(e.lon_deg * 1e7)
            alt_mm = round(e.alt_m * 1000)
            put(
                mavlink2.MAVLink_gps_raw_int_message(
                    unix_us, 3, lat, lon, alt_mm, 70, 110, 0, 0, sats
                ),
                e.utc,
            )
            put(
                mavlink2.MAVLink_global_position_int_message(
                    boot_ms, lat, lon, alt_mm, 0, 0, 0, 0, 0
                ),
                e.utc,
            )
    return out
