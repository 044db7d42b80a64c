"""Import of DJI flight-log CSV exports (AirData; PhantomHelp/TXTlogToCSVtool) as GpsFix lists.

DJI's own ``.txt`` flight records are encrypted; users export CSV. Column names:

* AirData: ``time(millisecond)``, ``datetime(utc)``, ``latitude``, ``longitude``,
  ``altitude_above_seaLevel(feet|meters)``, ``height_above_takeoff(feet|meters)``, ...
* PhantomHelp verbose: ``CUSTOM.updateTime``, ``OSD.latitude``, ``OSD.longitude``,
  ``OSD.height [m]`` or ``[ft]`` (height above take-off).

The unit is read from the header, never assumed; height above take-off is not MSL and is left
out of the fix rather than mislabelled. The files may hold NUL bytes and Latin-1 text.
For a replay the fix's ``t_host_ns`` is the log's own time since its first row (ns), so the
track can be re-timed onto a session clock.

Sub-second UTC: AirData's ``datetime(utc)`` holds whole seconds, while ``time(millisecond)``
counts the log's own clock in 0.1 s steps; every row's UTC is ``anchor + time(millisecond)``.
The anchor's whole seconds come from the rows (below); its fraction from the file's first fix:
AirData's own time base puts the first row with a position on the whole second written in that
row, and runs the log's clock from there (:func:`on_the_first_fix`). Measured on two real
exports with AirData's GPX of the same flight (tenths of a second): an Air 2S whose first fix
comes 11.6 s into its log and a Mini 2 with a fix from its first row, the GPX is that time at
every point, to the millisecond. The written second's own phase in the log's clock differs from
file to file (:func:`tick_phase`, where ``datetime(utc)`` changes: 0 mod 1000 in the Air 2S,
900 in the Mini 2; its seconds lead that time base by 0.6 s in one and 0.1 s in the other), so
the ticks bound the anchor and are reported, but do not set it. Real logs have gaps in
``time(millisecond)`` (the recorder paused)
and rows around a gap whose ``datetime(utc)`` is seconds off their neighbours', so the anchor is
never taken from one row: :func:`snrmon.drivers.gps.log_clock.anchored_utc` cuts the log at its
gaps, estimates each anchor from the whole-second bounds its rows agree on, and leaves the rows
that disagree out of the estimate (their fixes keep the anchor's time; the rows are counted and
named in :attr:`DjiLog.clock`). A UTC column written with fractions of a second is taken as
exact (rounded to its last digit).
Satellites: AirData ``satellites``, PhantomHelp ``OSD.gpsNum``.
"""

from __future__ import annotations

import csv
import io
import math
import re
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path

import numpy as np

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.log_clock import ClockReport, anchored_utc

MIN_TICKS = 1  # the phase is the most common over all ticks: one tick already pins it
_UNIT_TO_M = {"feet": 0.3048, "ft": 0.3048, "meters": 1.0, "metres": 1.0, "m": 1.0}
_UNIT = re.compile(r"^(?P<name>.+?)\s*[\(\[](?P<unit>[A-Za-z]+)[\)\]]$")


def _columns(header: list[str]) -> dict[str, tuple[int, float]]:
    """name (without unit) -> (index, factor to SI); the factor is 1 for unit-less columns."""
    cols: dict[str, tuple[int, float]] = {}
    for i, h in enumerate(header):
        h = h.strip()
        m = _UNIT.match(h)
        if m and m["unit"].lower() in _UNIT_TO_M:
            cols[m["name"].strip()] = (i, _UNIT_TO_M[m["unit"].lower()])
        elif m and m["name"].strip() == "altitude_above_seaLevel":
            continue  # an unknown unit: refused by the caller, never guessed
        else:
            cols[h] = (i, 1.0)
    return cols


def _time(text: str, where: str) -> datetime:
    for fmt in (
        "%Y-%m-%d %H:%M:%S.%f",
        "%Y-%m-%d %H:%M:%S",
        "%Y/%m/%d %H:%M:%S.%f",
        "%Y/%m/%d %H:%M:%S",
    ):
        try:
            return datetime.strptime(text.strip(), fmt).replace(tzinfo=UTC)
        except ValueError:
            continue
    raise ParseError(f"{where}: time {text!r} is not YYYY-MM-DD HH:MM:SS[.fff]")


@dataclass(frozen=True)
class DjiLog:
    """The fixes of a DJI log, in file order, and what its clock looked like (``clock`` is None
    where the log has no ``time(millisecond)`` and ``datetime(utc)`` pair to reconstruct)."""

    fixes: list[GpsFix]
    clock: ClockReport | None
    utc_source: str = "datetime(utc) + time(millisecond)"
    tick_phase_ms: int | None = None  # time(millisecond) mod 1000 where datetime(utc) changes
    ticks: int = 0  # second changes the phase was estimated from
    details: dict = field(default_factory=dict)


def read_dji_csv(path: str | Path) -> list[GpsFix]:
    """Every row with a position, in file order (:func:`read_dji_log` without the report)."""
    return read_dji_log(path).fixes


def read_dji_log(path: str | Path) -> DjiLog:
    """Every row with a position, in file order, each on the log's reconstructed UTC.

    Raises:
        ParseError: a header without latitude/longitude columns, or a row that does not decode
            (the message names the file, the line and the value).
    """
    path = Path(path)
    text = path.read_bytes().replace(b"\x00", b"").decode("latin-1")
    rows = csv.reader(io.StringIO(text))
    header = next(rows, None)
    if header is None:
        raise ParseError(f"{path}: empty file")
    read = _read_rows(path, rows, _dji_columns(path, header))
    if not any(math.isfinite(u) for u in read.clock_u):
        return DjiLog(read.fixes, None)
    timed = anchored_utc(
        read.clock_t,
        read.clock_u,
        where=read.clock_where,
        resolution_s=0.001 if read.fractional else 1.0,
        truncated=False,  # whole seconds rounded (module docstring); fractions: to the digit
    )
    utc_s = timed.utc_s
    phase = None if read.fractional else tick_phase(read.clock_t, read.clock_u)
    first_fix = next((i for i in read.fix_row if i is not None), None)
    if not read.fractional and first_fix is not None:
        t_log = np.asarray(read.clock_t, float)
        utc_s = on_the_first_fix(t_log, utc_s, first_fix, read.clock_u[first_fix])
    out = [
        f if i is None or not math.isfinite(utc_s[i]) else replace(f, utc=_utc_of(utc_s[i]))
        for f, i in zip(read.fixes, read.fix_row, strict=True)
    ]
    if phase is None:
        return DjiLog(out, timed.report)
    return DjiLog(
        out,
        timed.report,
        "datetime(utc) whole seconds, the first fix on its second + time(millisecond)",
        phase[0],
        phase[1],
        {"tick_phase_ms": phase[0], "ticks": phase[1], "ticks_at_phase": phase[2]},
    )


def _utc_of(utc_s: float) -> datetime:
    """``utc_s`` (s since 1970) to the microsecond: no float residue in the time."""
    us = round(utc_s * 1e6)
    return datetime.fromtimestamp(us // 10**6, UTC).replace(microsecond=us % 10**6)


_Column = tuple[int, float] | None
"""A column's (index, factor to SI), None where the file has none."""


@dataclass(frozen=True)
class _DjiColumns:
    """The columns a fix is read from."""

    lat: _Column
    lon: _Column
    msl: _Column
    utc: _Column
    ms: _Column
    sats: _Column


def _dji_columns(path: Path, header: list[str]) -> _DjiColumns:
    """The columns read, each under the first of its names the header has (AirData's, then
    TXTlogToCSVtool's)."""
    cols = _columns(header)

    def col(*names: str) -> _Column:
        return next((cols[n] for n in names if n in cols), None)

    lat_c, lon_c = col("latitude", "OSD.latitude"), col("longitude", "OSD.longitude")
    if lat_c is None or lon_c is None:
        raise ParseError(f"{path}: no latitude/longitude columns in header {header[:6]}...")
    msl_c = col("altitude_above_seaLevel")
    if msl_c is None and "altitude_above_seaLevel" in "".join(header):
        raise ParseError(f"{path}: altitude_above_seaLevel column without a known unit: {header}")
    utc_c = col("datetime(utc)", "CUSTOM.updateTime")
    return _DjiColumns(
        lat_c, lon_c, msl_c, utc_c, col("time(millisecond)"), col("satellites", "OSD.gpsNum")
    )


def _number(row: list[str], c: _Column, what: str, where: str) -> float | None:
    """_Column ``c`` of ``row`` in SI units; None where the row has no value there."""
    if c is None or c[0] >= len(row) or row[c[0]].strip() == "":
        return None
    try:
        v = float(row[c[0]])
    except ValueError:
        raise ParseError(f"{where}: {what} {row[c[0]]!r} is not a number") from None
    if not math.isfinite(v):
        raise ParseError(f"{where}: {what} {row[c[0]]!r} is not finite")
    return v * c[1]


@dataclass
class _DjiRows:
    """The rows' fixes and the log's clock: every row with a ``time(millisecond)`` has a row of
    the clock, its written UTC beside it."""

    fixes: list[GpsFix] = field(default_factory=list)
    fix_row: list[int | None] = field(default_factory=list)  # each fix's row of the clock
    clock_t: list[float] = field(default_factory=list)  # time(millisecond) / 1000
    clock_u: list[float] = field(default_factory=list)  # datetime(utc), s since 1970 (NaN: none)
    clock_where: list[str] = field(default_factory=list)
    fractional: bool = False  # a datetime(utc) with fractions of a second: exact, not whole


def _read_rows(path: Path, rows, c: _DjiColumns) -> _DjiRows:
    """Each row's fix (one with a position away from 0, 0) and clock reading, in file order."""
    out = _DjiRows()
    t0: datetime | None = None
    for lineno, row in enumerate(rows, start=2):
        if not row or all(not v.strip() for v in row):
            continue
        where = f"{path}:{lineno}"
        utc_text = row[c.utc[0]].strip() if c.utc is not None and c.utc[0] < len(row) else ""
        utc = _time(utc_text, where) if utc_text else None
        ms = _number(row, c.ms, "time", where)
        if ms is not None:
            out.clock_t.append(ms / 1000.0)
            out.clock_u.append(math.nan if utc is None else utc.timestamp())
            out.clock_where.append(where)
            out.fractional = out.fractional or (utc is not None and "." in utc_text)
        lat, lon = _number(row, c.lat, "latitude", where), _number(row, c.lon, "longitude", where)
        if lat is None or lon is None or (lat == 0.0 and lon == 0.0):
            continue  # DJI writes 0,0 before the first satellite fix
        if abs(lat) > 90 or abs(lon) > 180:
            raise ParseError(f"{where}: position {lat}, {lon} out of range")
        sats = _number(row, c.sats, "satellites", where)
        out.fix_row.append(None if ms is None else len(out.clock_t) - 1)
        if ms is not None:
            t_ns = round(ms * 1e6)
        elif utc is not None:
            t0 = t0 or utc
            t_ns = round((utc - t0).total_seconds() * 1e9)
        else:
            t_ns = len(out.fixes)
        out.fixes.append(
            GpsFix(
                t_host_ns=t_ns,
                utc=utc,
                lat_deg=lat,
                lon_deg=lon,
                alt_msl_m=_number(row, c.msl, "altitude", where),
                fix_quality=1,
                sats=None if sats is None else int(sats),
                raw=",".join(row),
            )
        )
    return out


def tick_phase(t_log_s: list[float], utc_whole_s: list[float]) -> tuple[int, int, int] | None:
    """Where in the log's own clock the whole-second ``datetime(utc)`` changes: (the phase,
    ``time(millisecond)`` mod 1000 in ms, the most common over every tick of the file; how many
    ticks; how many of them at that phase), or None where the file has fewer than
    ``MIN_TICKS``. A tick is a row whose written second is one more than the row before, one
    step of the log's clock earlier (rows across a gap say nothing about where the second
    changed)."""
    t = np.asarray(t_log_s, float)
    u = np.asarray(utc_whole_s, float)
    if t.size < 2:
        return None
    dt, du = np.diff(t), np.diff(u)
    step = float(np.median(dt[dt > 0])) if (dt > 0).any() else 0.0
    tick = (du == 1) & (dt > 0) & (dt <= 1.5 * step)
    if tick.sum() < MIN_TICKS:
        return None
    phases = np.round(t[1:][tick] * 1000).astype(np.int64) % 1000
    values, counts = np.unique(phases, return_counts=True)
    best = int(np.argmax(counts))
    return int(values[best]), int(tick.sum()), int(counts[best])


def on_the_first_fix(
    t_log_s: np.ndarray, utc_s: np.ndarray, first_fix: int, written_s: float
) -> np.ndarray:
    """Each row's UTC (``anchor + t_log``, from :func:`anchored_utc`) on AirData's time base:
    the first row with a position (row ``first_fix`` of the clock, its ``datetime(utc)``
    ``written_s``) on the whole second written in it, the log's clock running from there.

    The rows' whole-second bounds place an anchor to within a second whatever the file's phase,
    not to the right second (a file whose seconds lead its time base by 0.1 s reads 0.35 s early
    on them alone), so the first fix's anchor is its own row's second, checked against them
    (within a second of theirs); another anchor (a log whose clock stopped over a gap) keeps
    its rows' whole seconds and takes the same fraction, moved by less than half a second."""
    anchor = utc_s - t_log_s
    ours = anchor[first_fix]
    own = written_s - t_log_s[first_fix]
    target = own % 1.0
    move = (target - anchor) % 1.0
    move = np.where(move >= 0.5, move - 1.0, move)
    same = np.abs(anchor - ours) < 1e-6
    if math.isfinite(own) and abs(own - ours) < 1.0:
        move = np.where(same, own - anchor, move)
    return anchor + move + t_log_s
