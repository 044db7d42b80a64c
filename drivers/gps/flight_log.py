"""Every kind of flight log a field team brings, recognised by its content and read into fixes
(``snrmon gps-import``; docs/flight-logs.md).

:func:`detect_format` looks at the bytes, never the file name: a DataFlash log starts with its
FMT message, a ULog with its magic, a tlog with a plausible 8-byte receipt time followed by a
MAVLink start byte, a UBX log holds a UBX frame whose checksum matches; a text file is NMEA
(``$`` sentences), a DJI AirData CSV (a header with latitude and longitude columns) or a DJI SRT
(an index line, then a subtitle time code). :func:`read_flight_log` reads one into a
:class:`FlightLog`: the fixes that have a fix, in time order, how their UTC was obtained, what
the log's clock looked like, and what the reader measured on the way (lines moved to sort the
log, the autopilot's clock against the ground station's, a CSV's second-tick phase).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.fix import GpsFix

if TYPE_CHECKING:  # numpy: not for the command line's parser, which reads FORMATS
    from snrmon.drivers.gps.log_clock import ClockReport

FORMATS = ("dji_csv", "dji_srt", "nmea", "tlog", "dataflash", "ulog", "ubx")
SNIFF_BYTES = 1 << 16
UNIX_US_2000, UNIX_US_2100 = 946_684_800_000_000, 4_102_444_800_000_000


@dataclass
class FlightLog:
    """A log's fixes and what its reader found.

    Attributes:
        fixes: every fix with a fix, in time order.
        utc_source: how their UTC was obtained.
        clock: the log's clock (segments, gaps, jumps, outliers), where the reader checks it.
        local_time: the fixes' ``utc`` is the drone's local time with no zone (DJI SRT).
        dropped: positions read but without a fix (before the first lock, 0 N 0 E): not fixes.
        off_clock: fixes left out because their time is off the log's clock (jumps, repeats).
        details: measured figures for the record (``lines_moved``, ``clock_offset_s``, ...).
        notes: one line each for the operator, naming what was measured.
    """

    fixes: list[GpsFix]
    utc_source: str
    clock: ClockReport | None = None
    local_time: bool = False
    dropped: int = 0
    off_clock: int = 0
    details: dict = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)


def _tlog_start(head: bytes) -> bool:
    if len(head) < 9 or head[8] not in (0xFE, 0xFD):
        return False
    return UNIX_US_2000 < int.from_bytes(head[:8], "big") < UNIX_US_2100


def detect_format(path: str | Path) -> str:
    """The kind of flight log at ``path`` (one of :data:`FORMATS`), from its content.

    Raises:
        ParseError: none of them (the message names the file and what its start looks like).
    """
    from snrmon.drivers.gps.dataflash import MAGIC as DATAFLASH
    from snrmon.drivers.gps.dji_srt import looks_like_srt
    from snrmon.drivers.gps.ubx import SYNC, is_ubx_frame
    from snrmon.drivers.gps.ulog import MAGIC as ULOG

    p = Path(path)
    with p.open("rb") as fh:
        head = fh.read(SNIFF_BYTES)
    if head.startswith(ULOG):
        return "ulog"
    if head.startswith(DATAFLASH):
        return "dataflash"
    if _tlog_start(head):
        return "tlog"
    at = head.find(SYNC)
    while at >= 0:
        if is_ubx_frame(head, at):
            return "ubx"
        at = head.find(SYNC, at + 1)
    text = head.replace(b"\x00", b"").decode("latin-1")
    lines = [ln.strip() for ln in text.splitlines() if ln.strip() and not ln.startswith("#")]
    if lines and looks_like_srt(text):
        return "dji_srt"
    if lines and sum(ln.startswith("$") for ln in lines[:50]) >= max(1, len(lines[:50]) // 2):
        return "nmea"
    if lines and "latitude" in lines[0].lower() and "," in lines[0]:
        return "dji_csv"
    start = head[:16]
    raise ParseError(
        f"{p}: not a flight log snrmon reads (first bytes {start!r}); give --format "
        f"({', '.join(FORMATS)}) if it is one"
    )


def _counted(read: Any, utc_source: str) -> FlightLog:
    """A reader's log (``fixes``, ``clock``, ``no_fix``) whose every clock outlier is a fix."""
    off = 0 if read.clock is None else read.clock.outliers
    return FlightLog(read.fixes, utc_source, read.clock, dropped=read.no_fix, off_clock=off)


def read_flight_log(kind: str, path: str | Path) -> FlightLog:
    """The fixes of the flight log at ``path`` of ``kind`` (:data:`FORMATS`)."""
    p = Path(path)
    if kind == "dji_csv":
        from snrmon.drivers.gps.dji_csv import read_dji_log

        dji = read_dji_log(p)
        log = FlightLog(dji.fixes, dji.utc_source, dji.clock, details=dict(dji.details))
        if dji.tick_phase_ms is not None:
            log.notes.append(
                f"sub-second UTC from the file's own second ticks: datetime(utc) changes at "
                f"time(millisecond) = {dji.tick_phase_ms} mod 1000 ({dji.ticks} ticks)"
            )
        return log
    if kind == "dji_srt":
        from snrmon.drivers.gps.dji_srt import read_dji_srt

        srt = _counted(read_dji_srt(p), "the drone's local time")
        srt.local_time = True
        return srt
    if kind == "nmea":
        from snrmon.drivers.gps.nmea_log import read_nmea_log

        nmea = read_nmea_log(p)
        fixes = [f for f in nmea.fixes if f.has_fix]
        log = FlightLog(
            fixes,
            "NMEA RMC/ZDA date + GGA/RMC time",
            nmea.clock,
            dropped=len(nmea.fixes) - len(fixes),
            off_clock=nmea.off_clock,
            details={"lines_moved": nmea.lines_moved},
        )
        if nmea.lines_moved:
            log.notes.append(
                f"the log's lines were out of time order: sorted by their own UTC, "
                f"{nmea.lines_moved} of {len(nmea.fixes)} epochs moved"
            )
        return log
    if kind == "tlog":
        from snrmon.drivers.gps.tlog import read_tlog

        tlog = read_tlog(p)
        log = FlightLog(
            tlog.fixes,
            tlog.utc_source,
            tlog.clock,
            dropped=tlog.no_fix,
            off_clock=tlog.off_clock,
            details={"clock_offset_s": tlog.clock_offset_s},
        )
        if tlog.clock_offset_s is not None:
            log.notes.append(tlog.describe_clock_offset())
        return log
    if kind == "dataflash":
        from snrmon.drivers.gps.dataflash import read_dataflash

        return _counted(read_dataflash(p), "GPS week and ms (GWk, GMS) - leap seconds")
    if kind == "ulog":
        from snrmon.drivers.gps.ulog import read_ulog

        ulg = read_ulog(p)
        return _counted(ulg, f"{ulg.topic}.time_utc_usec")
    if kind == "ubx":
        from snrmon.drivers.gps.ubx import read_ubx

        return _counted(read_ubx(p), "NAV-PVT date, time and nano")
    raise ValueError(f"flight log format must be one of {', '.join(FORMATS)}, got {kind!r}")
