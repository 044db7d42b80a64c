"""Every number of the SNR-versus-range report, from a session file or a live session (paper
sections 7-9). From a file (:func:`report_data`) the session is replayed through the live
measurement; live (:func:`live_report_data`, the headless demo's end-of-flight report) the stop
table's own rows and the frames each summarised are used as measured.

- Fig. 6: per stop and camera, the 100-frame series of peak value, background (rim) mean,
  background std and peak SNR: the frames :func:`snrmon.acquisition.stops.detector.summarise_stop`
  chose from a replay of the session through the live measurement.
- Figs. 7-10: per camera, the measured points (mean with the sample std as error bar, against the
  stop's range: the rangefinder's, else the GPS slant range) over the model's four curves
  (:func:`snrmon.model.snr.predict`), the Fig. 12 band around the corrected curves and the
  resolved/unresolved transition ranges (characteristic dimension = pixel footprint).
- Fig. 12: the uncertainty budget (:class:`snrmon.model.uncertainty.UncertaintyBudget`) of the
  session's sensor and target at each stop's range, term by term, for the small dimension.
- The CSV rows (:mod:`snrmon.acquisition.report.stop_csv`): one per stop and camera, with the ratio
  of the measured SNR mean to each model curve at the stop's range.

The sensors are the session's ``[cameras.<name>] sensor`` presets and the target is the
session's ``target`` unless one is given.
"""

from __future__ import annotations

import bisect
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.prediction import CURVES, EXPECTED_CURVES, ModelPredictor
from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.replay.batch import ReplayResult, replay_session
from snrmon.acquisition.report.stop_csv import csv_rows
from snrmon.acquisition.stops.detector import summarise_stop
from snrmon.acquisition.stops.table import StopRow, StopTable

BUDGET_TERMS: tuple[str, ...] = (
    "target_outline",
    "radiometry",
    "transmission",
    "path_radiance",
    "mtf",
    "target_size_blur",
)


@dataclass(frozen=True)
class StopSeries:
    """Paper Fig. 6 for one stop and camera: the frames of the stop's summary run, in order.

    ``t_s`` is each frame's host time from the stop's start; arrays are in DN except ``snr``.
    """

    camera: str
    stop: int
    range_m: float | None
    complete: bool
    t_s: np.ndarray
    peak: np.ndarray
    bg_mean: np.ndarray
    bg_std: np.ndarray
    snr: np.ndarray


@dataclass(frozen=True)
class MeasuredPoints:
    """One camera's stops with a range and at least one valid frame (Figs. 7-10 markers)."""

    camera: str
    stop: np.ndarray
    range_m: np.ndarray
    snr_mean: np.ndarray
    snr_std: np.ndarray
    snr_sem: np.ndarray  # the error of the mean (frames' autocorrelation counted)
    n_frames: np.ndarray
    complete: np.ndarray


@dataclass(frozen=True)
class ModelCurves:
    """The model's four curves for one camera's sensor and the target (Figs. 7-10)."""

    camera: str
    sensor: str
    target: str
    atmosphere: str
    background_temp_k: float
    ranges_m: np.ndarray
    snr: dict[str, np.ndarray]
    lower: dict[str, np.ndarray]
    upper: dict[str, np.ndarray]
    transition_small_m: float
    transition_large_m: float
    # What the corrected curves' PSF is: "sensor preset" or the PSF measured from the flight.
    psf_label: str = "sensor preset"


@dataclass(frozen=True)
class BudgetAtRange:
    """Fig. 12 for one camera at one range: each relative term and their combination."""

    camera: str
    range_m: float
    resolved: bool
    terms: dict[str, float]
    total: float
    combine: str


@dataclass(frozen=True)
class ReportData:
    path: Path
    target: str
    sensors: dict[str, str]
    rows: list[StopRow]
    series: list[StopSeries]
    measured: dict[str, MeasuredPoints]
    models: dict[str, ModelCurves]
    budgets: dict[str, list[BudgetAtRange]]
    csv_rows: list[dict[str, object]]
    replay_seconds: float | None  # None: measured live, not replayed
    recording_seconds: float
    fits: list = field(default_factory=list)  # comparison.FitStatistic per camera and curve
    references: list = field(default_factory=list)  # comparison.Reference
    detections: dict = field(default_factory=dict)  # camera -> comparison.DetectionSummary


def session_models(path: str | Path, target: str | None = None) -> tuple[dict[str, str], str]:
    """({camera: sensor preset}, target) of a session: its configuration, ``target`` if given.
    Without a session configuration each camera's name is taken as its sensor preset."""
    with open_session(path) as f:
        cameras = list(f.cameras)
        raw = f.config.get("session") if isinstance(f.config, dict) else None
    sensors = {c: c for c in cameras}
    session_target = "uav1"
    if raw:
        cfg = session_config_from_dict(raw)
        sensors.update({c.name: c.sensor for c in cfg.cameras if c.name in sensors})
        session_target = cfg.target
    return sensors, target or session_target


def stop_series(replay: ReplayResult, row: StopRow, n: int = 100) -> StopSeries:
    """Fig. 6 data of one stop row: the summary run of the row's camera during the stop."""
    cam = replay.cameras[row.camera]
    lo = bisect.bisect_left(cam.t_host_ns, row.t_start_ns)
    hi = (
        len(cam.t_host_ns)
        if row.t_end_ns is None
        else bisect.bisect_left(cam.t_host_ns, row.t_end_ns)
    )
    stream = cam.results[lo:hi]
    run = summarise_stop(stream, n).frames
    return run_series(row, cam.t_host_ns[lo:hi][run], stream[run])


def run_series(row: StopRow, t_host_ns, frames) -> StopSeries:
    """Fig. 6 data of one stop row from the frames of its summary run (host times in ns)."""
    times = np.asarray(t_host_ns, dtype=np.int64)

    def arr(name: str) -> np.ndarray:
        return np.array([getattr(m, name) for m in frames], dtype=float)

    return StopSeries(
        camera=row.camera,
        stop=row.stop,
        range_m=row.range_m,
        complete=row.complete,
        t_s=(times - row.t_start_ns) / 1e9,
        peak=arr("peak"),
        bg_mean=arr("bg_mean"),
        bg_std=arr("bg_std"),
        snr=arr("snr"),
    )


def measured_points(rows: list[StopRow], camera: str) -> MeasuredPoints:
    keep = [r for r in rows if r.camera == camera and r.range_m is not None and r.n_frames > 0]
    return MeasuredPoints(
        camera=camera,
        stop=np.array([r.stop for r in keep], dtype=int),
        range_m=np.array([r.range_m for r in keep], dtype=float),
        snr_mean=np.array([r.snr_mean for r in keep], dtype=float),
        snr_std=np.array([r.snr_std for r in keep], dtype=float),
        snr_sem=np.array([r.snr_sem for r in keep], dtype=float),
        n_frames=np.array([r.n_frames for r in keep], dtype=int),
        complete=np.array([r.complete for r in keep], dtype=bool),
    )


def model_range_grid(stop_ranges_m: list[float]) -> np.ndarray:
    """Ranges for the curves: the paper's 10-600 m, widened to hold every stop with margin."""
    lo = min([10.0, *(0.5 * r for r in stop_ranges_m)])
    hi = max([600.0, *(1.5 * r for r in stop_ranges_m)])
    return np.geomspace(lo, hi, 400)


def model_curves(
    camera: str, sensor_name: str, target_name: str, ranges_m, **predict_options
) -> ModelCurves:
    """The four curves and their bands; ``predict_options`` go to :func:`snrmon.model.snr.predict`
    (a campaign's ``[model]`` settings)."""
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict

    p = predict(load_sensor(sensor_name), load_target(target_name), ranges_m, **predict_options)
    psf = predict_options.get("corrected_psf")
    snr = {c: np.asarray(p.snr(c), float) for c in CURVES}
    for name in EXPECTED_CURVES:
        snr[name] = np.asarray(p.snr(name), float)
    snr.update({f"paper_{c}": np.asarray(v, float) for c, v in p.paper.items()})
    return ModelCurves(
        camera=camera,
        sensor=sensor_name,
        target=target_name,
        atmosphere=p.atmosphere_name,
        background_temp_k=p.background_temp_k,
        ranges_m=p.ranges_m,
        snr=snr,
        lower={c: np.asarray(v, float) for c, v in p.lower.items()},
        upper={c: np.asarray(v, float) for c, v in p.upper.items()},
        transition_small_m=p.transition_range_small_m,
        transition_large_m=p.transition_range_large_m,
        psf_label="sensor preset" if psf is None else psf_label(psf),
    )


def psf_label(psf) -> str:
    """The PSF the stop rows' corrected values came from, in a few words for a title (the
    console adopts the one measured from the flight: Airy x a Gaussian blur)."""
    sigma = getattr(psf, "sigma_px", None)
    name = {"AiryGaussianPsf": "Airy x Gaussian blur", "GaussianPsf": "Gaussian sigma"}.get(
        type(psf).__name__, type(psf).__name__
    )
    return (
        f"the stop rows' ({name} {sigma:.2f} px)"
        if sigma is not None
        else f"the stop rows' ({name})"
    )


def rows_sky_k(rows: list[StopRow], camera: str) -> float | None:
    """The background (sky) temperature to draw ``camera``'s curves at: the median of the one
    its stop rows' model values were computed for (the measured sky where the session's model
    followed it, paper sections 8-9), so the curves are those the stops are compared with; None
    (the model's own) without such rows."""
    temps = [r.model_sky_temp_k for r in rows if r.camera == camera and r.model_sky_temp_k]
    return float(np.median(temps)) if temps else None


def rows_psf(rows: list[StopRow], camera: str):
    """The corrected PSF to draw ``camera``'s curves with: the one its last stop row's model
    values were computed with (a PSF measured from the flight, once the console adopted one),
    so the curves are those the rows are compared with; None (the sensor preset's) without."""
    psfs = [r.model_psf for r in rows if r.camera == camera and r.model_psf is not None]
    return psfs[-1] if psfs else None


def uncertainty_budget(
    camera: str, sensor_name: str, target_name: str, ranges_m: list[float]
) -> list[BudgetAtRange]:
    """Fig. 12 terms at each range for the small dimension, with the model's default budget.

    The path-radiance term is the budget's fraction times L_bg / (L_t - L_bg) (section 9's
    amplification); the model exposes that factor through a budget holding only that term at
    1, so every number here is the model's own."""
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.model.snr import predict
    from snrmon.model.uncertainty import UncertaintyBudget

    if not ranges_m:
        return []
    sensor, target = load_sensor(sensor_name), load_target(target_name)
    r = np.asarray(ranges_m, float)
    budget = UncertaintyBudget()
    unit_path = UncertaintyBudget(
        target_outline=0.0,
        radiometry=0.0,
        transmission=0.0,
        path_radiance=1.0,
        mtf=0.0,
        target_size_blur=0.0,
    )
    p = predict(sensor, target, r, uncertainty=unit_path)
    amp = np.asarray(p.relative_uncertainty["small_corrected"], float)
    unresolved = ~np.asarray(p.resolved_small, bool)
    total = budget.relative(amp, unresolved)
    out = []
    for i, rng in enumerate(r):
        terms = {
            "target_outline": budget.target_outline,
            "radiometry": budget.radiometry,
            "transmission": budget.transmission,
            "path_radiance": budget.path_radiance * float(amp[i]),
            "mtf": budget.mtf if unresolved[i] else 0.0,
            "target_size_blur": budget.target_size_blur if unresolved[i] else 0.0,
        }
        out.append(
            BudgetAtRange(
                camera, float(rng), not unresolved[i], terms, float(total[i]), budget.combine
            )
        )
    return out


def report_data(
    path: str | Path,
    *,
    target: str | None = None,
    frames_per_stop: int = 100,
    progress: Callable[[int, int], None] | None = None,
) -> ReportData:
    """Replay the session (every frame through the live measurement) and compute the report."""
    path = Path(path)
    sensors, target_name = session_models(path, target)
    predictor = ModelPredictor(sensors, target_name)
    replay = replay_session(path, predictor=predictor, progress=progress)
    rows = replay.stops
    return assemble_report(
        path,
        sensors,
        target_name,
        rows,
        [stop_series(replay, r, frames_per_stop) for r in rows],
        seconds=replay.recording_seconds,
        replay_seconds=replay.seconds,
    )


def live_report_data(
    table: StopTable, sensors: dict[str, str], target: str, *, name: str, seconds: float
) -> ReportData:
    """The report of a session still in memory, from its stop table: the rows as the console
    measured them and, for Fig. 6, the frames each row summarised. Nothing is replayed, so no
    recording is needed (``replay_seconds`` None); ``name`` labels it in place of a file."""
    rows = [r for r in table.rows() if r.camera in sensors]
    runs = table.runs()
    series = []
    for r in rows:
        run = runs.get((r.stop, r.camera))
        if run is not None:  # a row still collecting has no final run yet
            series.append(run_series(r, [t for t, _ in run], [m for _, m in run]))
    return assemble_report(Path(name), sensors, target, rows, series, seconds=seconds)


def assemble_report(
    path: Path,
    sensors: dict[str, str],
    target: str,
    rows: list[StopRow],
    series: list[StopSeries],
    *,
    seconds: float,
    replay_seconds: float | None = None,
) -> ReportData:
    """Figs. 7-10 and 12 and the CSV for measured stop rows: the model at the sensors' presets
    and the target, over a range grid that holds every stop."""
    stop_ranges = [r.range_m for r in rows if r.range_m is not None]
    grid = model_range_grid(stop_ranges)
    cameras = list(dict.fromkeys([*sensors, *(r.camera for r in rows)]))
    budgets = {}
    for c in cameras:
        ranges = sorted({r.range_m for r in rows if r.camera == c and r.range_m is not None})
        budgets[c] = uncertainty_budget(c, sensors[c], target, ranges)
    from snrmon.acquisition.report.comparison import (
        detection_summary,
        fit_statistics,
        reference_table,
    )

    models = {}
    for c in cameras:
        psf = rows_psf(rows, c)
        extra = {} if psf is None else {"corrected_psf": psf}
        models[c] = model_curves(
            c, sensors[c], target, grid, background_temp_k=rows_sky_k(rows, c), **extra
        )
    return ReportData(
        path=path,
        target=target,
        sensors=sensors,
        rows=rows,
        series=series,
        measured={c: measured_points(rows, c) for c in cameras},
        models=models,
        budgets=budgets,
        csv_rows=csv_rows(rows),
        replay_seconds=replay_seconds,
        recording_seconds=seconds,
        fits=fit_statistics(rows, models),
        references=reference_table(sensors, target),
        detections={c: detection_summary(c, sensors[c], target) for c in cameras},
    )
