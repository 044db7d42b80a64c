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
    from snrmon.acquisition.config import session_config_from_dict
    from snrmon.acquisition.measure.peak_snr import RUNNING_EXCLUDED, PeakSnrConfig, flags_to_bits
    from snrmon.acquisition.prediction import CURVES, ModelPredictor, session_model_options
    from snrmon.acquisition.record.gps_align import host_to_utc_ns
    from snrmon.acquisition.record.gps_import import gps_source
    from snrmon.acquisition.record.reader import open_session
    from snrmon.acquisition.replay.batch import replay_session

    t0 = time.perf_counter()
    with open_session(path) as f:
        if camera not in f.cameras:
            raise ValueError(f"session file {path} has no camera {camera!r}")
        raw = f.config.get("session") if isinstance(f.config, dict) else None
        cfg = session_config_from_dict(raw) if raw else None
        clock = f.clock
        n_frames = f.cameras[camera].n_frames
    recorded = cfg.measurement if cfg else PeakSnrConfig()
    measurement = settings.measurement_config(recorded)
    sensor = settings.sensors.get(camera) or next(
        (c.sensor for c in (cfg.cameras if cfg else ()) if c.name == camera), camera
    )
    target = settings.target or (cfg.target if cfg else "uav1")
    # the session's [weather] unless the campaign sets the atmosphere itself
    options = {**session_model_options(cfg), **settings.model_options}
    predictor = ModelPredictor({camera: sensor}, target, **options)
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
        predictor=predictor,
        redetect_stops=redetect,
    )
    rep = result.cameras[camera]
    sky = _model_sky_temp_k(sensor, target, settings.model_options)
    method = background_method(measurement)
    times = np.asarray(rep.t_host_ns, np.int64)
    bits = np.array([flags_to_bits(r.flags) for r in rep.results], np.int64)
    excluded = flags_to_bits(RUNNING_EXCLUDED)
    stop_of = np.full(len(times), -1, np.int64)
    name = label or Path(path).stem
    rows = []
    for r in result.stops:
        end = np.iinfo(np.int64).max if r.t_end_ns is None else r.t_end_ns
        inside = (times >= r.t_start_ns) & (times < end)
        stop_of[inside] = r.stop
        start_utc, end_utc = host_to_utc_ns(
            np.array([r.t_start_ns, r.t_end_ns if r.t_end_ns is not None else r.t_start_ns]), clock
        )
        flags = [
            name
            for name, on in (
                ("incomplete", not r.complete),
                ("manual", r.manual),
                ("stop_open_at_end", r.t_end_ns is None),
                ("no_range", r.range_m is None),
                ("gps_imported", source == "imported"),
            )
            if on
        ]
        n, std = r.n_frames, _none(r.snr_std)
        row: dict[str, Any] = {
            "session": name,
            "session_path": os.path.abspath(path),
            "camera": camera,
            "stop": r.stop,
            "target": target,
            "sensor": sensor,
            "day": datetime.fromtimestamp(int(start_utc) / 1e9, tz=UTC).date(),
            "t_start_utc": int(start_utc),
            "t_end_utc": int(end_utc) if r.t_end_ns is not None else None,
            "lrf_range_m": _none(r.lrf_range_m),
            "gps_range_m": _none(r.gps_range_m),
            "range_m": _none(r.range_m),
            "gps_source": source,
            "stops_source": "redetected" if redetect else "recorded",
            "n_frames": n,
            "complete": r.complete,
            "snr_mean": _none(r.snr_mean),
            "snr_std": std,
            "snr_sem": _none(r.snr_sem),
            "n_frames_in_stop": int(inside.sum()),
            "n_frames_flagged": int(((bits[inside] & excluded) != 0).sum()),
            "background_method": method,
            "background_used": r.background or None,
            "box_px": measurement.box_px,
            "search_px": measurement.search_px,
            "calibration": cal,
            "sky_temp_k": sky if r.model_sky_temp_k is None else r.model_sky_temp_k,
            **{f"model_{c}": _none(r.model_snr.get(c)) for c in CURVES},
            "resolved_small": r.resolved,
            "flags": flags,
        }
        rows.append(row)
    cols = None
    if frames:
        res = rep.results
        cols = {
            "session": np.array([name] * len(res), dtype=object),
            "camera": np.array([camera] * len(res), dtype=object),
            "t_host_ns": times,
            "utc": host_to_utc_ns(times, clock) if len(times) else times,
            "stop": stop_of,
            "peak_x": np.array([r.peak_x for r in res], np.int32),
            "peak_y": np.array([r.peak_y for r in res], np.int32),
            "peak": np.array([r.peak for r in res], float),
            "bg_mean": np.array([r.bg_mean for r in res], float),
            "bg_std": np.array([r.bg_std for r in res], float),
            "snr": np.array([r.snr for r in res], float),
            "flags": bits.astype(np.uint16),
        }
    return TaskResult(
        session=name,
        camera=camera,
        stops=rows,
        frames=cols,
        n_frames=n_frames,
        n_measured=len(rep.results),
        seconds=time.perf_counter() - t0,
        info={"sensor": sensor, "target": target, "gps_source": source, "background": method},
    )
