"""A DJI video's telemetry subtitles (``.SRT``, written beside each video) as GpsFix lists, for
importing a drone's own record into a session (``snrmon gps-import``).

Each subtitle block is one video frame (newer drones) or one second (older ones): an index, the
video time code, and text with the drone's date and time and its position. The layouts in use:

* newer (Air 2S, Mini, Mavic 3): ``2022-08-07 13:40:40,774,808`` (seconds, ms, us) and
  ``[latitude: 41.424724] [longitude: 2.234156]``, with ``[rel_alt: ..] [abs_alt: ..]`` on the
  drones that write them (``[altitude: ..]`` on others, whose reference DJI does not state);
* older (Mavic Pro, Phantom 4): ``2017.08.05 14:11:51`` (or ``2017.8.5``) and
  ``GPS(longitude,latitude,N)`` (longitude first; the third number is not an altitude, it runs
  13..16 on a drone 1.9 m up: DJI_SRT_Parser calls it one, we do not), heights ``BAROMETER``,
  ``H`` or ``Hb`` above the take-off point.

Only ``abs_alt`` is an altitude above sea level; every other height is above the take-off point
and is left out of the fix rather than mislabelled. The date and time are the drone's **local
time, with no zone**: the fixes' ``utc`` holds that local time as read (marked by
``SrtLog.local_time``), for the import to place on UTC with the zone the operator gives or the
session's own UTC tells (:mod:`snrmon.acquisition.record.gps_import`). A block at 0, 0 (before
the first satellite fix) is dropped. A file whose blocks carry no date (some Phantom 4 RTK
firmware writes only the video time code) cannot be placed on any clock: refused.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.log_clock import ClockReport, fixes_on_their_clock

_NUM = r"[-+]?\d+(?:\.\d+)?"
_DATE = re.compile(
    r"(\d{4})[-.](\d{1,2})[-.](\d{1,2})\s+(\d{1,2}):(\d{2}):(\d{2})(?:[,.](\d{1,3}))?(?:,(\d{1,3}))?"
)
_LAT = re.compile(rf"\[latitude\s*:\s*({_NUM})\]")
_LON = re.compile(rf"\[longitude\s*:\s*({_NUM})\]")
_ABS_ALT = re.compile(rf"abs_alt\s*:\s*({_NUM})")
_GPS = re.compile(rf"GPS\s*\(\s*({_NUM})\s*,\s*({_NUM})\s*(?:,[^)]*)?\)")
_TIMECODE = re.compile(r"^\d{2}:\d{2}:\d{2},\d{3}\s*-->\s*\d{2}:\d{2}:\d{2},\d{3}", re.MULTILINE)


@dataclass
class SrtLog:
    fixes: list[GpsFix]  # utc: the drone's local time as written (no zone)
    clock: ClockReport | None = None
    blocks: int = 0
    no_fix: int = 0  # blocks at 0, 0 or without a position: dropped
    local_time: bool = True


def looks_like_srt(text: str) -> bool:
    """A subtitle file: an index line, then a time code line ``00:00:00,000 --> ...``."""
    lines = [ln.strip() for ln in text.lstrip("\ufeff").splitlines() if ln.strip()]
    return len(lines) >= 2 and lines[0].isdigit() and bool(_TIMECODE.match(lines[1]))


def _local_time(m: re.Match, where: str) -> datetime:
    y, mo, d, h, mi, s = (int(x) for x in m.groups()[:6])
    ms = int((m[7] or "0").ljust(3, "0"))
    us = int((m[8] or "0").ljust(3, "0")) if m[8] else 0
    try:
        return datetime(y, mo, d, h, mi, s, ms * 1000 + us, tzinfo=UTC)
    except ValueError:
        raise ParseError(f"{where}: date {m[0]!r} is not a date and time") from None


def read_dji_srt(path: str | Path) -> SrtLog:
    """Every subtitle block with a position and a date (module docstring).

    Raises:
        FileNotFoundError: no such file.
        ParseError: not a subtitle file, no date in any block, or no position.
    """
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"DJI SRT {p} not found")
    text = p.read_bytes().decode("utf-8", errors="replace")
    if not looks_like_srt(text):
        raise ParseError(f"{p}: not a subtitle file (no index and time code lines)")
    out = SrtLog([])
    where: list[str] = []
    dated = 0
    line_no = 1
    for block in re.split(r"\r?\n\s*\r?\n", text.strip()):
        start = line_no
        line_no += block.count("\n") + 2
        if not _TIMECODE.search(block):
            continue
        out.blocks += 1
        here = f"{p}:{start}"
        date = _DATE.search(block)
        if date is None:
            continue
        dated += 1
        lat_m, lon_m, gps = _LAT.search(block), _LON.search(block), _GPS.search(block)
        if lat_m and lon_m:
            lat, lon = float(lat_m[1]), float(lon_m[1])
        elif gps:
            lon, lat = float(gps[1]), float(gps[2])
        else:
            out.no_fix += 1
            continue
        if lat == 0.0 and lon == 0.0:
            out.no_fix += 1
            continue
        if abs(lat) > 90 or abs(lon) > 180:
            raise ParseError(f"{here}: position {lat}, {lon} out of range")
        alt = _ABS_ALT.search(block)
        out.fixes.append(
            GpsFix(
                t_host_ns=0,
                utc=_local_time(date, here),
                lat_deg=lat,
                lon_deg=lon,
                alt_msl_m=float(alt[1]) if alt else None,
                fix_quality=1,
                raw=" ".join(block.split())[:500],
            )
        )
        where.append(here)
    if not dated:
        raise ParseError(
            f"{p}: no date and time in its {out.blocks} subtitle blocks (only the video's "
            "time code): it cannot be placed on a clock"
        )
    read = f"{out.blocks} subtitle blocks, {out.no_fix} at 0, 0 or without a position"
    out.fixes, out.clock = fixes_on_their_clock(out.fixes, where, log=p, read=read)
    return out
