"""The rows of the recorded streams (``docs/session-format.md``): what a rangefinder reading, a
GPS fix or a measured frame becomes in the session file (:func:`range_row`, :func:`gps_row`,
:func:`measurement_row`, in the field order of :mod:`snrmon.acquisition.record.schema`), and what a
recorded row becomes again (:func:`reading_from_row`, :func:`fix_from_row`,
:func:`measurement_from_row`), so that a replay sees what the operator saw. Missing values are
NaN (floats) or -1 (integers) in the file and None in the data types.
"""

from __future__ import annotations

import math
from datetime import UTC, datetime, timedelta
from typing import Any

import numpy as np

from snrmon.acquisition.engine.inputs import Measurement
from snrmon.acquisition.measure.peak_snr import PeakSnr, flags_from_bits
from snrmon.acquisition.record import schema as S  # noqa: N812
from snrmon.acquisition.track.config import TrackState
from snrmon.drivers.gps.fix import GpsFix
from snrmon.drivers.rangefinder.reading import RangeReading, RangeStatus

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


def reading_from_row(row: np.void) -> RangeReading:
    """The :class:`RangeReading` a recorded /rangefinder row came from."""
    quality = int(row["quality"])
    return RangeReading(
        t_host_ns=int(row["t_host_ns"]),
        range_m=_opt(row["range_m"]),
        status=RangeStatus(S.text_value(row["status"])),
        horizontal_m=_opt(row["horizontal_m"]),
        azimuth_deg=_opt(row["azimuth_deg"]),
        inclination_deg=_opt(row["inclination_deg"]),
        quality=None if quality < 0 else quality,
        raw=S.text_value(row["raw"]),
    )


def peak_snr_cells(r: PeakSnr) -> tuple:
    """The Eq. (4) result's cells of a measurement row, in the order of its declared columns
    (:data:`snrmon.acquisition.record.schema.PEAK_SNR_COLUMNS`)."""
    return tuple(c.file_value(getattr(r, c.field)) for c in S.PEAK_SNR_COLUMNS)


def measurement_row(index: int | None, m: Measurement) -> tuple:
    """A /cameras/<name>/measurements row (``index``: the frame's index in the file, None when
    the recorder dropped it)."""
    cue = m.cue_xy if m.cue_xy is not None else (math.nan, math.nan)
    return (
        -1 if index is None else int(index),
        m.counter,
        m.t_host_ns,
        *peak_snr_cells(m.result),
        S.text_field(m.track_state.value, S.STATE_TEXT_BYTES),
        m.window_xy[0],
        m.window_xy[1],
        float(cue[0]),
        float(cue[1]),
        m.snr_mean,
        m.snr_std,
        m.snr_n,
        _nan(m.range_m),
        S.text_field(m.range_source, 8),
    )


def values_row(index: int, *, counter: int, t_host_ns: int, **values: Any) -> tuple:
    """A measurement row from Eq. (4)'s values alone (a frame measured without the engine's
    context: the track state is empty, the window is the peak, the rest is "not given").
    ``values``: the fields of :class:`PeakSnr` by name (``flags`` as names or bits, none by
    default; a field left out takes its default)."""
    flags = values.pop("flags", 0)
    if isinstance(flags, (int, np.integer)):
        flags = flags_from_bits(int(flags))
    r = PeakSnr(flags=frozenset(flags), **values)
    nan = math.nan
    return (
        index,
        counter,
        t_host_ns,
        *peak_snr_cells(r),
        b"",
        r.peak_x,
        r.peak_y,
        nan,
        nan,
        nan,
        nan,
        0,
        nan,
        b"",
    )


def peak_snr_from_row(row: np.void) -> PeakSnr:
    """The Eq. (4) result a measurement row holds."""
    return PeakSnr(**{c.field: c.record_value(row[c.name]) for c in S.PEAK_SNR_COLUMNS})


def track_state_of(row: np.void) -> TrackState:
    """The track state a measurement row records; a row written without the engine's context
    (an empty state: a fixed window, no tracker) reads as ``fixed``."""
    text = S.text_value(row["track_state"])
    return TrackState(text) if text else TrackState.FIXED


def measurement_from_row(camera: str, row: np.void, seq: int = -1) -> Measurement:
    """The :class:`Measurement` a format 2 measurement row came from."""
    cx, cy = float(row["cue_x"]), float(row["cue_y"])
    rng = float(row["range_m"])
    return Measurement(
        camera=camera,
        seq=seq,
        counter=int(row["counter"]),
        t_host_ns=int(row["t_host_ns"]),
        result=peak_snr_from_row(row),
        track_state=track_state_of(row),
        window_xy=(int(row["window_x"]), int(row["window_y"])),
        snr_mean=float(row["snr_mean"]),
        snr_std=float(row["snr_std"]),
        snr_n=int(row["snr_n"]),
        range_m=rng if math.isfinite(rng) else None,
        range_source=S.text_value(row["range_source"]),
        cue_xy=(cx, cy) if math.isfinite(cx) and math.isfinite(cy) else None,
    )
