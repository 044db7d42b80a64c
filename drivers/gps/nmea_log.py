"""A receiver's NMEA 0183 log file (one sentence a line, as ``gpspipe -r`` or a logger writes
it) as one :class:`GpsFix` per epoch, for importing a drone's or a receiver's own log into a
session (``snrmon gps-import --nmea``).

The lines go through the same :class:`snrmon.drivers.gps.nmea.NmeaAssembler` as a live receiver.
An epoch's GGA and RMC (same UTC) are merged into one fix, each field taken from whichever
sentence carries it (GGA: altitude, quality, satellites, HDOP; RMC: the date). Lines starting
with ``#`` and blank lines are skipped (gpsd's regression logs carry comments); a line that does
not decode is counted and skipped, because a logger's file often holds a torn line where it was
stopped. A fix before the receiver gave a date has no UTC and cannot be placed on a session's
clock: it is counted in ``without_utc`` and left out. ``t_host_ns`` of each fix is the log's
own time: ns since its first epoch's UTC.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from datetime import datetime
from pathlib import Path

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.nmea import NmeaAssembler


@dataclass
class NmeaLog:
    """The fixes of a log, one per epoch in UTC order, and what was skipped."""

    fixes: list[GpsFix]
    lines: int = 0
    bad_lines: int = 0
    without_utc: int = 0
    first_error: str | None = None
    by_address: dict[str, int] = field(default_factory=dict)


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
    epochs: dict[datetime, GpsFix] = {}
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
            elif f.utc in epochs:
                # RMC and GGA of one epoch: an invalid RMC (quality 0) voids the pair.
                epochs[f.utc] = _merge(epochs[f.utc], f)
            else:
                epochs[f.utc] = f
    out.by_address = dict(asm.counts.by_address)
    if not epochs:
        why = f" (first bad line: {out.first_error})" if out.first_error else ""
        raise ParseError(f"{p}: no NMEA fix with a UTC date and time in {out.lines} lines{why}")
    first = min(epochs)
    out.fixes = [
        replace(f, t_host_ns=round((u - first).total_seconds() * 1e9))
        for u, f in sorted(epochs.items())
    ]
    return out
