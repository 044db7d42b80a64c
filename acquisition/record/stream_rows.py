"""The rows of the recorded streams (``docs/session-format.md``): what a rangefinder reading or a
GPS fix becomes in the session file (:func:`range_row`, :func:`gps_row`, in the field order of
:mod:`acquisition.record.schema`), and what a recorded GPS row becomes again
(:func:`fix_from_row`), so that a replay shows the fix the operator saw. Missing values are NaN
(floats) or -1 (integers) in the file and None in the data types.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime, timedelta

import numpy as np

from acquisition.record import schema as S  # noqa: N812
from drivers.gps.fix import GpsFix
from drivers.rangefinder.reading import RangeReading

EPOCH = datetime(1970, 1, 1, tzinfo=UTC)


def _nan(v: float | None) -> float:
    return math.nan if v is None else float(v)


def range_row(reading: RangeReading) -> tuple:
    """A /rangefinder row (the UTC column is filled by the writer)."""
    return (
        reading.t_host_ns,
        0,
        _nan(reading.range_m),
        S.text_field(str(reading.status), S.NAME_BYTES),
        _nan(reading.horizontal_m),
        _nan(reading.azimuth_deg),
        _nan(reading.inclination_deg),
        -1 if reading.quality is None else int(reading.quality),
        S.text_field(reading.raw, S.RAW_BYTES),
    )


def gps_row(fix: GpsFix) -> tuple:
    """A /gps row (the UTC column is filled by the writer; ``fix_utc_ns`` is the receiver's)."""
    fix_utc = -1
    if fix.utc is not None:
        u = fix.utc if fix.utc.tzinfo else fix.utc.replace(tzinfo=UTC)
        d = u - EPOCH
        fix_utc = (d.days * 86400 + d.seconds) * 10**9 + d.microseconds * 1000
    return (
        fix.t_host_ns,
        0,
        fix_utc,
        _nan(fix.lat_deg),
        _nan(fix.lon_deg),
        _nan(fix.alt_msl_m),
        _nan(fix.alt_ellipsoid_m),
        int(fix.fix_quality),
        -1 if fix.sats is None else int(fix.sats),
        _nan(fix.hdop),
        S.text_field(fix.raw, S.GPS_RAW_BYTES),
    )


def _opt(value: float) -> float | None:
    return float(value) if math.isfinite(value) else None


def fix_from_row(row: np.void) -> GpsFix:
    """The :class:`GpsFix` a recorded /gps row came from: the inverse of :func:`gps_row`."""
    fix_utc_ns = int(row["fix_utc_ns"])
    utc = None
    if fix_utc_ns >= 0:
        utc = EPOCH + timedelta(microseconds=fix_utc_ns // 1000)
    sats = int(row["sats"])
    raw = bytes(row["raw"]).decode("utf-8", errors="replace")
    return GpsFix(
        t_host_ns=int(row["t_host_ns"]),
        utc=utc,
        lat_deg=_opt(row["lat_deg"]),
        lon_deg=_opt(row["lon_deg"]),
        alt_msl_m=_opt(row["alt_msl_m"]),
        alt_ellipsoid_m=_opt(row["alt_ellipsoid_m"]),
        fix_quality=int(row["fix_quality"]),
        sats=None if sats < 0 else sats,
        hdop=_opt(row["hdop"]),
        raw=raw,
    )
