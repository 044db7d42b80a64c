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
from snrmon.drivers.gps.log_clock import ClockReport

LIVE_COPY = "gps_live"
SOURCE_ATTR = "source"
IMPORTED = "imported"
KINDS = ("dji_csv", "nmea", "tlog")


@dataclass(frozen=True)
class GpsImport:
    """What an import did (also the ``import_json`` attribute and the event's payload)."""

    session: str
    log: str
    kind: str
    log_sha256: str
    utc_source: str
    fixes_in_log: int
    fixes_written: int
    fixes_outside: int  # more than ``margin_s`` outside the session's span: not written
    first_utc_ns: int
    last_utc_ns: int
    offset: OffsetSearch
    live_rows_kept: int  # live rows moved to /gps_live (0: there were none)
    flags_cleared: bool
    clock: dict | None = None  # the log's own clock: segments, gaps, jumps, outliers left out

    def as_dict(self) -> dict:
        d = {k: v for k, v in self.__dict__.items() if k != "offset"}
        d["offset"] = self.offset.as_dict()
        return d


def _sha256(path: Path) -> str:
    h = hashlib.sha256()
    with path.open("rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def _utc_ns(fix: GpsFix) -> int:
    return int(gps_row(fix)[2])


def read_log(kind: str, path: str | Path) -> tuple[list[GpsFix], str, ClockReport | None]:
    """(fixes, how their UTC was obtained, what the log's own clock looked like: its segments,
    gaps, time jumps and the rows left out) of a flight log of ``kind`` (:data:`KINDS`)."""
    if kind == "dji_csv":
        from snrmon.drivers.gps.dji_csv import read_dji_log

        dji = read_dji_log(path)
        return dji.fixes, "datetime(utc) + time(millisecond)", dji.clock
    if kind == "nmea":
        from snrmon.drivers.gps.nmea_log import read_nmea_log

        nmea = read_nmea_log(path)
        return nmea.fixes, "NMEA RMC/ZDA date + GGA/RMC time", nmea.clock
    if kind == "tlog":
        from snrmon.drivers.gps.tlog import read_tlog

        log = read_tlog(path)
        return log.fixes, log.utc_source, log.clock
    raise ValueError(f"flight log kind must be one of {', '.join(KINDS)}, got {kind!r}")


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
) -> GpsImport:
    """Align the flight log ``log`` to ``session`` on UTC and write it as its ``/gps``.

    ``offset_s`` None searches the offset against the rangefinder (applied only when it is
    identifiable, :func:`snrmon.acquisition.record.gps_align.search_offset`); a number is applied as
    given (the search still runs and is reported). Fixes more than ``margin_s`` outside the
    session's recorded span are left out.
    """
    session, log = Path(session), Path(log)
    if not session.is_file():
        raise FileNotFoundError(f"session file {session} not found")
    if not log.is_file():
        raise FileNotFoundError(f"flight log {log} not found")
    fixes, utc_source, clock = read_log(kind, log)
    fixes = [f for f in fixes if f.utc is not None and f.lat_deg is not None]
    if not fixes:
        raise ValueError(f"{log}: no fix with a position and a UTC time")
    fixes.sort(key=_utc_ns)
    utc = np.array([_utc_ns(f) for f in fixes], np.int64)
    f, flags_cleared = _open_rw(session)
    try:
        if f.attrs.get("format") != S.FORMAT:
            raise ValueError(f"{session} is not a snrmon session file (format attribute missing)")
        gps = f[S.GPS]
        live = gps.attrs.get(SOURCE_ATTR, "live") != IMPORTED and gps.shape[0] > 0
        if live and not replace:
            raise ValueError(
                f"{session} already holds {gps.shape[0]} live GPS rows; give --replace to "
                f"import the log anyway (the live rows are kept in /{LIVE_COPY})"
            )
        t_host = utc_to_host_ns(utc, f[S.CLOCK][()])
        search = _offset(f, fixes, t_host, offset_s, max_offset_s)
        shift = round(search.offset_s * 1e9)
        span = _span_ns(f)
        keep = np.ones(len(fixes), bool)
        if span is not None:
            margin = round(margin_s * 1e9)
            keep = (t_host + shift >= span[0] - margin) & (t_host + shift <= span[1] + margin)
        rows = []
        for fix, t, u, k in zip(fixes, t_host, utc, keep, strict=True):
            if k:
                row = list(gps_row(fix))
                row[0], row[1] = int(t + shift), int(u + shift)
                rows.append(tuple(row))
        kept = 0
        if live:
            kept = gps.shape[0]
            if LIVE_COPY not in f:
                copy_rows(f, gps, LIVE_COPY)
                f[LIVE_COPY].attrs[SOURCE_ATTR] = "live"
        resize_rows(gps, len(rows))
        if rows:
            gps[:] = np.array(rows, dtype=S.GPS_DTYPE)
        result = GpsImport(
            session=str(session),
            log=str(log),
            kind=kind,
            log_sha256=_sha256(log),
            utc_source=utc_source,
            fixes_in_log=len(fixes),
            fixes_written=len(rows),
            fixes_outside=int((~keep).sum()),
            first_utc_ns=int(utc[0]),
            last_utc_ns=int(utc[-1]),
            offset=search,
            live_rows_kept=kept,
            flags_cleared=flags_cleared,
            clock=None if clock is None else clock.as_dict(),
        )
        gps.attrs[SOURCE_ATTR] = IMPORTED
        gps.attrs["import_json"] = json.dumps(result.as_dict())
    finally:
        f.close()
    payload = result.as_dict()
    payload["log"] = Path(payload["log"]).name[:200]  # the event's payload field is bounded
    if payload["clock"] is not None:  # the counts; the named rows are in /gps's import_json
        payload["clock"] = {k: v for k, v in payload["clock"].items() if k != "examples"}
    payload.pop("session")
    append_event(session, "gps_imported", payload=payload)
    return result


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
    from dataclasses import replace as dc_replace

    return dc_replace(found, offset_s=float(offset_s), applied=True, reason="given by the user")


def gps_source(path: str | os.PathLike) -> str | None:
    """``"live"``, ``"imported"`` or None (no GPS rows) for a session's ``/gps``."""
    with h5py.File(path, "r", swmr=True) as f:
        gps = f[S.GPS]
        if gps.shape[0] == 0:
            return None
        return str(gps.attrs.get(SOURCE_ATTR, "live"))
