"""Recording a drone's own flight log as a session's GPS stream (``snrmon gps-import``).

A campaign often has sessions whose live GPS feed was missing. The drone kept its own log (a DJI
flight record exported by AirData, a receiver's NMEA log, a MAVLink ``.tlog``); its fixes are
placed on the session's clock on UTC (:mod:`snrmon.acquisition.record.gps_align`, with the offset
search against the rangefinder where the session has one) and written as the session's ``/gps``, so
the GPS range, the stop detector and the cueing of a replay and of a campaign use them as they would
a live feed.

The file is a finished SWMR session; it is opened ``r+`` with plain h5py and stays readable by
plain h5py. ``/gps`` gets the attribute ``source = "imported"`` (a live stream has ``"live"`` or
no attribute) and ``import_json`` (what was imported and how it was aligned); an event
``gps_imported`` records the same. A session that already holds live GPS rows is refused unless
``replace=True``, and then its live rows are first copied, untouched, to ``/gps_live``: nothing
recorded is lost. See ``docs/session-format.md``.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass
from dataclasses import replace as dc_replace
from datetime import timedelta
from pathlib import Path

import h5py
import numpy as np

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.geo.projection import Site
from snrmon.acquisition.record import schema as S  # noqa: N812
from snrmon.acquisition.record.gps_align import (
    OffsetSearch,
    search_offset,
    slant_ranges_m,
    utc_to_host_ns,
)
from snrmon.acquisition.record.reader import append_event, clear_status_flags
from snrmon.acquisition.record.stream_rows import gps_row
from snrmon.acquisition.record.writer import copy_rows, resize_rows
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.gps.flight_log import FORMATS, FlightLog, read_flight_log
from snrmon.drivers.gps.log_clock import ClockReport

LIVE_COPY = "gps_live"
SOURCE_ATTR = "source"
IMPORTED = "imported"
KINDS = FORMATS
MIN_WRITTEN = 0.5  # an import that would write less than this share of the log's fixes: refused
UTC_OFFSET_STEP_S = 900  # time zones are whole quarter hours
UTC_OFFSETS_S = range(-12 * 3600, 14 * 3600 + 1, UTC_OFFSET_STEP_S)


@dataclass(frozen=True)
class LogRead:
    """The flight log an import read: the file, its format and digest, and what its reader
    found besides the fixes."""

    path: str
    kind: str
    sha256: str
    clock: dict | None = None  # the log's own clock: segments, gaps, jumps, outliers left out
    dropped_no_fix: int = 0  # positions in the log without a fix: never written
    details: dict | None = None  # what the reader measured (lines moved, clock offset, ...)
    notes: tuple[str, ...] = ()  # the same, one line each for the operator


@dataclass(frozen=True)
class FixesPlaced:
    """The log's fixes as placed on the session's host clock: how many there were and were
    written, their UTC span, the offset applied and how their UTC was obtained."""

    in_log: int
    written: int
    outside: int  # more than ``margin_s`` outside the session's span: not written
    first_utc_ns: int
    last_utc_ns: int
    offset: OffsetSearch
    utc_source: str
    utc_offset_s: float | None = None  # local time - UTC applied (a DJI SRT), else None


@dataclass(frozen=True)
class GpsImport:
    """What an import did (also the ``import_json`` attribute and the event's payload): the
    log read, its fixes placed on the session, what became of the session's live rows."""

    session: str
    flight_log: LogRead
    placed: FixesPlaced
    live_rows_kept: int  # live rows moved to /gps_live (0: there were none)
    flags_cleared: bool

    def as_dict(self) -> dict:
        """The summary as ``import_json`` holds it (docs/session-format.md): one flat object."""
        log, placed = self.flight_log, self.placed
        return {
            "session": self.session,
            "log": log.path,
            "kind": log.kind,
            "log_sha256": log.sha256,
            "utc_source": placed.utc_source,
            "fixes_in_log": placed.in_log,
            "fixes_written": placed.written,
            "fixes_outside": placed.outside,
            "first_utc_ns": placed.first_utc_ns,
            "last_utc_ns": placed.last_utc_ns,
            "live_rows_kept": self.live_rows_kept,
            "flags_cleared": self.flags_cleared,
            "clock": log.clock,
            "dropped_no_fix": log.dropped_no_fix,
            "utc_offset_s": placed.utc_offset_s,
            "details": log.details,
            "notes": log.notes,
            "offset": placed.offset.as_dict(),
        }


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _utc_ns(fix: GpsFix) -> int:
    return int(gps_row(fix)[2])


def read_log(kind: str, path: str | Path) -> tuple[list[GpsFix], str, ClockReport | None]:
    """(fixes, how their UTC was obtained, what the log's own clock looked like) of a flight log
    of ``kind`` (:data:`KINDS`): :func:`snrmon.drivers.gps.flight_log.read_flight_log`."""
    log = read_flight_log(kind, path)
    return log.fixes, log.utc_source, log.clock


def _session_site(f: h5py.File) -> Site | None:
    config = json.loads(f.attrs.get("config_json", "{}"))
    raw = config.get("session") if isinstance(config, dict) else None
    return session_config_from_dict(raw).site if raw else None


def _span_ns(f: h5py.File) -> tuple[int, int] | None:
    """First and last host time of anything the session recorded (frames and range)."""
    times = [f[f"{S.CAMERAS}/{c}/t_host_ns"][()] for c in f[S.CAMERAS]]
    times.append(f[S.RANGEFINDER]["t_host_ns"])
    times = [np.asarray(t) for t in times if len(t)]
    if not times:
        return None
    return int(min(t.min() for t in times)), int(max(t.max() for t in times))


def _open_rw(path: Path) -> tuple[h5py.File, bool]:
    try:
        return h5py.File(path, "r+"), False
    except OSError as exc:
        if "h5clear" not in str(exc) and "consistency flags" not in str(exc):
            raise OSError(
                f"cannot open session file {path} for writing: {str(exc).splitlines()[0]}"
            ) from exc
    # A session left by a crash: its flags are cleared as h5clear -s does, then it is written.
    clear_status_flags(path)
    return h5py.File(path, "r+"), True


def import_gps_log(
    session: str | os.PathLike,
    log: str | os.PathLike,
    kind: str,
    *,
    replace: bool = False,
    offset_s: float | None = None,
    max_offset_s: float = 10.0,
    margin_s: float = 60.0,
    utc_offset_s: float | None = None,
) -> GpsImport:
    """Align the flight log ``log`` to ``session`` on UTC and write it as its ``/gps``.

    ``offset_s`` None searches the offset against the rangefinder (applied only when it is
    identifiable, :func:`snrmon.acquisition.record.gps_align.search_offset`); a number is applied as
    given (the search still runs and is reported). Fixes more than ``margin_s`` outside the
    session's recorded span are left out. A log whose times are the drone's local time (a DJI
    SRT) is placed on UTC with ``utc_offset_s`` (local time - UTC) where given, else with the
    one whole quarter hour that puts it within the session (:func:`_local_time_offset`).

    Raises:
        ValueError: the log has no fix, or the import would write fewer than ``MIN_WRITTEN`` of
            its fixes (outside the session, times out of order): ``/gps`` is left unchanged.
    """
    session, log = Path(session), Path(log)
    if not session.is_file():
        raise FileNotFoundError(f"session file {session} not found")
    if not log.is_file():
        raise FileNotFoundError(f"flight log {log} not found")
    flight = read_flight_log(kind, log)
    fixes = [f for f in flight.fixes if f.utc is not None and f.has_fix]
    if not fixes:
        raise ValueError(f"{log}: no fix in the log ({flight.dropped} positions without a fix)")
    f, flags_cleared = _open_rw(session)
    try:
        gps, live = _gps_to_write(f, session, replace)
        rows, placed = _placed_on_session(
            f, log, flight, fixes, offset_s, max_offset_s, margin_s, utc_offset_s
        )
        kept = _write_rows(f, gps, live, rows)
        result = GpsImport(
            session=str(session),
            flight_log=LogRead(
                path=str(log),
                kind=kind,
                sha256=_sha256(log),
                clock=None if flight.clock is None else flight.clock.as_dict(),
                dropped_no_fix=flight.dropped,
                details=flight.details,
                notes=tuple(flight.notes),
            ),
            placed=placed,
            live_rows_kept=kept,
            flags_cleared=flags_cleared,
        )
        gps.attrs[SOURCE_ATTR] = IMPORTED
        gps.attrs["import_json"] = json.dumps(result.as_dict())
    finally:
        f.close()
    append_event(session, "gps_imported", payload=_event_payload(result))
    return result


def _gps_to_write(f: h5py.File, session: Path, replace: bool) -> tuple[h5py.Dataset, bool]:
    """The session's ``/gps`` and whether it holds live rows (refused unless ``replace``)."""
    if f.attrs.get("format") != S.FORMAT:
        raise ValueError(f"{session} is not a snrmon session file (format attribute missing)")
    gps = f[S.GPS]
    live = gps.attrs.get(SOURCE_ATTR, "live") != IMPORTED and gps.shape[0] > 0
    if live and not replace:
        raise ValueError(
            f"{session} already holds {gps.shape[0]} live GPS rows; give --replace to "
            f"import the log anyway (the live rows are kept in /{LIVE_COPY})"
        )
    return gps, live


def _placed_on_session(
    f: h5py.File,
    log: Path,
    flight: FlightLog,
    fixes: list[GpsFix],
    offset_s: float | None,
    max_offset_s: float,
    margin_s: float,
    utc_offset_s: float | None,
) -> tuple[list[tuple], FixesPlaced]:
    """(the ``/gps`` rows to write, how they were placed): the fixes on the session's clock
    (local time resolved, the offset searched), those more than ``margin_s`` outside the
    session's span left out; refused (ValueError) when fewer than ``MIN_WRITTEN`` of the log's
    fixes would be written."""
    utc_source = flight.utc_source
    in_log = len(fixes) + flight.off_clock
    span = _span_ns(f)
    margin = round(margin_s * 1e9)
    local_offset = None
    if flight.local_time:
        local_offset, how = _local_time_offset(
            log, fixes, utc_offset_s, f[S.CLOCK][()], span, margin
        )
        shift_local = timedelta(seconds=local_offset)
        fixes = [dc_replace(x, utc=x.utc - shift_local) for x in fixes if x.utc is not None]
        utc_source = f"{utc_source} - {_hhmm(local_offset)} ({how})"
    fixes.sort(key=_utc_ns)
    utc = np.array([_utc_ns(x) for x in fixes], np.int64)
    t_host = utc_to_host_ns(utc, f[S.CLOCK][()])
    search = _offset(f, fixes, t_host, offset_s, max_offset_s)
    shift = round(search.offset_s * 1e9)
    keep = np.ones(len(fixes), bool)
    if span is not None:
        keep = (t_host + shift >= span[0] - margin) & (t_host + shift <= span[1] + margin)
    if keep.sum() < MIN_WRITTEN * in_log:
        raise ValueError(
            _why_refused(
                log, int(keep.sum()), in_log, flight.off_clock, flight.clock, t_host + shift, span
            )
        )
    rows = []
    for fix, t, u, k in zip(fixes, t_host, utc, keep, strict=True):
        if k:
            row = list(gps_row(fix))
            row[0], row[1] = int(t + shift), int(u + shift)
            rows.append(tuple(row))
    return rows, FixesPlaced(
        in_log=in_log,
        written=len(rows),
        outside=int((~keep).sum()),
        first_utc_ns=int(utc[0]),
        last_utc_ns=int(utc[-1]),
        offset=search,
        utc_source=utc_source,
        utc_offset_s=local_offset,
    )


def _write_rows(f: h5py.File, gps: h5py.Dataset, live: bool, rows: list[tuple]) -> int:
    """Write ``rows`` as ``/gps``; live rows are first copied to ``/LIVE_COPY`` (once). Returns
    the number of live rows kept there."""
    kept = 0
    if live:
        kept = gps.shape[0]
        if LIVE_COPY not in f:
            copy_rows(f, gps, LIVE_COPY)
            f[LIVE_COPY].attrs[SOURCE_ATTR] = "live"
    resize_rows(gps, len(rows))
    if rows:
        gps[:] = np.array(rows, dtype=S.GPS_DTYPE)
    return kept


def _event_payload(result: GpsImport) -> dict:
    """The ``gps_imported`` event's payload: the import's summary, bounded for the event row."""
    payload = result.as_dict()
    payload["log"] = Path(payload["log"]).name[:200]  # the event's payload field is bounded
    if payload["clock"] is not None:  # the counts; the named rows are in /gps's import_json
        payload["clock"] = {k: v for k, v in payload["clock"].items() if k != "examples"}
    payload.pop("session")
    return payload


def _hhmm(offset_s: float) -> str:
    sign = "-" if offset_s < 0 else "+"
    minutes = round(abs(offset_s) / 60)
    return f"UTC{sign}{minutes // 60:02d}:{minutes % 60:02d}"


def _local_time_offset(
    log: Path, fixes: list[GpsFix], given_s: float | None, clock_rows, span, margin: int
) -> tuple[float, str]:
    """(local time - UTC in seconds, how it was chosen) for a log in the drone's local time:
    the offset given, or the one whole quarter hour that puts at least ``MIN_WRITTEN`` of its
    fixes within the session's span (the session's own UTC). Refused when none does, or when
    several do (a session longer than a quarter hour): then the operator gives it."""
    if given_s is not None:
        return float(given_s), "--utc-offset"
    if span is None:
        raise ValueError(
            f"{log} is in the drone's local time and the session has no frames to place it by: "
            "give --utc-offset"
        )
    local = np.array([_utc_ns(x) for x in fixes], np.int64)
    fits = []
    for off in UTC_OFFSETS_S:
        t = utc_to_host_ns(local - off * 10**9, clock_rows)
        inside = int(((t >= span[0] - margin) & (t <= span[1] + margin)).sum())
        if inside >= MIN_WRITTEN * len(fixes):
            fits.append(off)
    if len(fits) == 1:
        return float(fits[0]), "from the session's own UTC"
    if not fits:
        raise ValueError(
            f"{log} is in the drone's local time and no time zone puts it within the session "
            "(its date or the session's is wrong): give --utc-offset"
        )
    raise ValueError(
        f"{log} is in the drone's local time and {len(fits)} time zones put it within the "
        f"session ({', '.join(_hhmm(o) for o in fits[:4])}): give --utc-offset"
    )


def _why_refused(log: Path, written: int, in_log: int, off_clock: int, clock, t_host, span) -> str:
    """Why an import would keep fewer than half of the log's fixes, for the refusal."""
    head = f"{log}: the import would write {written} of the log's {in_log} fixes, refused"
    if off_clock > in_log / 2 and clock is not None:
        first = f"; first: {clock.examples[0]}" if clock.examples else ""
        return (
            f"{head}: times out of order, {off_clock} fixes are off the log's clock{first} "
            "(/gps unchanged)"
        )
    assert span is not None
    if t_host.max() < span[0]:
        where = f"the log ends {(span[0] - t_host.max()) / 1e9:.1f} s before the session starts"
    elif t_host.min() > span[1]:
        where = f"the log starts {(t_host.min() - span[1]) / 1e9:.1f} s after the session ends"
    else:
        where = "most of its fixes lie outside the session's span"
    return f"{head}: outside the session, {where} (/gps unchanged)"


def _offset(
    f: h5py.File, fixes: list[GpsFix], t_host: np.ndarray, offset_s, max_offset_s
) -> OffsetSearch:
    site = _session_site(f)
    lrf = f[S.RANGEFINDER][()]
    ok = (lrf["status"] == b"ok") & np.isfinite(lrf["range_m"]) & (lrf["range_m"] > 0)
    alt = np.array([math.nan if x.alt_msl_m is None else x.alt_msl_m for x in fixes])
    has = np.isfinite(alt)
    if site is None or not ok.any() or has.sum() < 2:
        why = (
            "the session has no site, so no GPS range"
            if site is None
            else "no rangefinder reading to fit"
            if not ok.any()
            else "the log has no altitudes"
        )
        given = 0.0 if offset_s is None else float(offset_s)
        return OffsetSearch(
            given,
            offset_s is not None,
            f"no offset search: {why}",
            (-max_offset_s, max_offset_s),
            0.01,
            0,
            0.0,
            None,
            None,
            None,
        )
    lat = np.array([x.lat_deg for x in fixes])[has]
    lon = np.array([x.lon_deg for x in fixes])[has]
    r_gps = slant_ranges_m(site, lat, lon, alt[has])
    t = t_host[has]
    order = np.argsort(t, kind="stable")
    interval_s = float(np.median(np.diff(t[order]))) / 1e9 if len(t) > 1 else 0.0
    found = search_offset(
        t[order],
        r_gps[order],
        lrf["t_host_ns"][ok],
        lrf["range_m"][ok],
        max_offset_s=max_offset_s,
        min_offset_s=interval_s,
    )
    if offset_s is None:
        return found
    return dc_replace(found, offset_s=float(offset_s), applied=True, reason="given by the user")


def gps_source(path: str | os.PathLike) -> str | None:
    """``"live"``, ``"imported"`` or None (no GPS rows) for a session's ``/gps``."""
    with h5py.File(path, "r", swmr=True) as f:
        gps = f[S.GPS]
        if gps.shape[0] == 0:
            return None
        return str(gps.attrs.get(SOURCE_ATTR, "live"))
