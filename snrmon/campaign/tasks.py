"""The work of one campaign task: one camera of one session through the replay engine.

A worker opens the session file by path (shared filesystem; nothing large travels through the
scheduler) and returns only rows: one dict per stop (:data:`snrmon.campaign.tables.STOP_COLUMNS`)
and, on request, the per-frame columns. The measurement is
:func:`snrmon.acquisition.replay.batch.replay_session` restricted to the camera, with the analysis's
Eq. (4) settings and calibration, so a campaign's stop rows equal ``snrmon replay``'s.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from snrmon.campaign.settings import AnalysisSettings


@dataclass
class TaskResult:
    """What one (session, camera) task sends back."""

    session: str  # the path as the user gave it
    camera: str
    stops: list[dict[str, Any]]
    frames: dict[str, np.ndarray] | None
    n_frames: int  # frames of this camera in the recording
    n_measured: int  # frames the replay measured (the ROI was set)
    seconds: float
    info: dict[str, Any] = field(default_factory=dict)


def session_cameras(path: str) -> list[str]:
    """The cameras of a session file (the planning task; fails clearly on a bad file)."""
    from snrmon.acquisition.record.reader import open_session

    with open_session(path) as f:
        if not f.cameras:
            raise ValueError(f"session file {path} holds no camera")
        return list(f.cameras)


def background_method(config) -> str:
    """How Eq. (4)'s background was taken: ``rim`` or ``rect x0,y0,x1,y1``, ``+detrend``."""
    method = "rim" if config.background is None else "rect " + ",".join(map(str, config.background))
    return method + ("+detrend" if config.detrend else "")


def _model_sky_temp_k(sensor: str, target: str, options: dict) -> float:
    """The background (sky) temperature the model curves used: the analysis's, else the
    model's own for the sensor's band (:func:`snrmon.model.snr.predict`)."""
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict

    p = predict(load_sensor(sensor), load_target(target), np.array([100.0]), **options)
    return float(p.background_temp_k)


def _none(v: float | None) -> float | None:
    return None if v is None or not math.isfinite(v) else float(v)


@dataclass(frozen=True)
class _Recorded:
    """What the analysis takes from the session file before replaying it."""

    config: Any  # the recorded SessionConfig (None: the file has none)
    clock: np.ndarray
    n_frames: int


def _recorded(path: str, camera: str) -> _Recorded:
    from snrmon.acquisition.config import session_config_from_dict
    from snrmon.acquisition.record.reader import open_session

    with open_session(path) as f:
        if camera not in f.cameras:
            raise ValueError(f"session file {path} has no camera {camera!r}")
        raw = f.config.get("session") if isinstance(f.config, dict) else None
        cfg = session_config_from_dict(raw) if raw else None
        return _Recorded(cfg, f.clock, f.cameras[camera].n_frames)


def analyse_camera(
    path: str,
    camera: str,
    settings: AnalysisSettings,
    *,
    frames: bool = False,
    label: str | None = None,
) -> TaskResult:
    """Replay ``camera`` of the session at ``path`` with ``settings``; the stop rows (and the
    per-frame columns with ``frames``). ``label`` is the session's name in the table."""
    from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
    from snrmon.acquisition.prediction import ModelPredictor, session_model_options
    from snrmon.acquisition.record.gps_import import gps_source
    from snrmon.acquisition.replay.batch import replay_session

    t0 = time.perf_counter()
    rec = _recorded(path, camera)
    cfg = rec.config
    measurement = settings.measurement_config(cfg.measurement if cfg else PeakSnrConfig())
    sensor = settings.sensors.get(camera) or next(
        (c.sensor for c in (cfg.cameras if cfg else ()) if c.name == camera), camera
    )
    target = settings.target or (cfg.target if cfg else "uav1")
    # the session's [weather] unless the campaign sets the atmosphere itself
    options = {**session_model_options(cfg), **settings.model_options}
    cal = settings.calibrations.get(camera)
    source = gps_source(path)
    # The recorded stops carry the live GPS ranges; an imported GPS stream needs them found
    # again from the streams (its ranges and the stop detector's use of them).
    redetect = settings.stops == "redetect" or source == "imported"
    result = replay_session(
        path,
        cameras=[camera],
        fast=settings.fast,
        measurement=measurement,
        calibrations={camera: cal} if cal else None,
        track=settings.track_flag,
        predictor=ModelPredictor({camera: sensor}, target, **options),
        redetect_stops=redetect,
    )
    rep = result.cameras[camera]
    name = label or Path(path).stem
    times = np.asarray(rep.t_host_ns, np.int64)
    method = background_method(measurement)
    given = {
        "session": name,
        "session_path": os.path.abspath(path),
        "target": target,
        "sensor": sensor,
        "gps_source": source,
        "stops_source": "redetected" if redetect else "recorded",
        "background_method": method,
        "box_px": measurement.box_px,
        "search_px": measurement.search_px,
        "calibration": cal,
    }
    sky = _model_sky_temp_k(sensor, target, settings.model_options)
    rows, stop_of = stop_rows(result.stops, rep.results, times, rec.clock, given, sky)
    return TaskResult(
        session=name,
        camera=camera,
        stops=rows,
        frames=frame_columns(rep.results, times, stop_of, rec.clock, name, camera)
        if frames
        else None,
        n_frames=rec.n_frames,
        n_measured=len(rep.results),
        seconds=time.perf_counter() - t0,
        info={"sensor": sensor, "target": target, "gps_source": source, "background": method},
    )


def stop_rows(
    stops: list,
    results: list,
    times: np.ndarray,
    clock: np.ndarray,
    given: dict[str, Any],
    sky_temp_k: float,
) -> tuple[list[dict[str, Any]], np.ndarray]:
    """(one row of :data:`snrmon.campaign.tables.STOP_COLUMNS` per stop row, each frame's stop
    index (-1: none)): ``given`` the analysis's columns, ``sky_temp_k`` the model's sky where a
    row has none of its own (no model followed a measured sky)."""
    from snrmon.acquisition.measure.peak_snr import RUNNING_EXCLUDED, flags_to_bits
    from snrmon.acquisition.record.gps_align import host_to_utc_ns
    from snrmon.acquisition.stops.columns import default_keys, stop_record

    bits = np.array([flags_to_bits(r.flags) for r in results], np.int64)
    excluded = flags_to_bits(RUNNING_EXCLUDED)
    stop_of = np.full(len(times), -1, np.int64)
    keys = default_keys()

    def utc(t_host_ns: int) -> int:
        return int(host_to_utc_ns(np.array([t_host_ns], np.int64), clock)[0])

    rows = []
    for r in stops:
        end = np.iinfo(np.int64).max if r.place.t_end_ns is None else r.place.t_end_ns
        inside = (times >= r.place.t_start_ns) & (times < end)
        stop_of[inside] = r.stop
        row = {**given, **stop_record(r, utc=utc, keys=keys)}
        for k, v in row.items():  # missing or not finite: null
            if isinstance(v, float):
                row[k] = _none(v)
        row["background"] = r.reading.background or None
        if row["model_sky_temp_k"] is None:
            row["model_sky_temp_k"] = sky_temp_k
        row["day"] = datetime.fromtimestamp(row["t_start_utc"] / 1e9, tz=UTC).date()
        row["n_frames_in_stop"] = int(inside.sum())
        row["n_frames_flagged"] = int(((bits[inside] & excluded) != 0).sum())
        row["flags"] = stop_flags(r, given["gps_source"])
        rows.append(row)
    return rows, stop_of


def stop_flags(r, gps_source: str | None) -> list[str]:
    """What a stop row's reader should know of it, by name (:data:`STOP_COLUMNS` ``flags``)."""
    return [
        name
        for name, on in (
            ("incomplete", not r.reading.complete),
            ("manual", r.manual),
            ("stop_open_at_end", r.place.t_end_ns is None),
            ("no_range", r.range_m is None),
            ("gps_imported", gps_source == "imported"),
        )
        if on
    ]


def frame_columns(
    results: list,
    times: np.ndarray,
    stop_of: np.ndarray,
    clock: np.ndarray,
    session: str,
    camera: str,
) -> dict[str, np.ndarray]:
    """The per-frame columns (:data:`snrmon.campaign.tables.FRAME_COLUMNS`): which frame, then
    each declared column of the Eq. (4) result (flags as their bits)."""
    from snrmon.acquisition.record.gps_align import host_to_utc_ns
    from snrmon.acquisition.record.schema import PEAK_SNR_COLUMNS

    n = len(results)
    cols: dict[str, np.ndarray] = {
        "session": np.array([session] * n, dtype=object),
        "camera": np.array([camera] * n, dtype=object),
        "t_host_ns": times,
        "utc": host_to_utc_ns(times, clock) if n else times,
        "stop": stop_of,
    }
    for c in PEAK_SNR_COLUMNS:
        values = [getattr(r, c.field) for r in results]
        if c.dtype.startswith("S"):  # text: as it is, not the file's bytes
            cols[c.name] = np.array(values, dtype=object)
        else:
            cols[c.name] = np.array([c.file_value(v) for v in values], c.dtype)
    return cols
