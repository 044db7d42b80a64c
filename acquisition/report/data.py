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
- The 3D noise table: per stop and camera, the 3D noise of the background clear of the target
  over the stop's summary frames (:mod:`snrmon.acquisition.replay.stop_noise`), and per camera
  the root mean square over its stops. With ``noise="measured"`` (the operator's "measured
  noise") each camera's sigma_tvh and sigma_vh from that table replace the model's noise
  (:class:`snrmon.model.noise.MeasuredNoise`) in the stop rows' model values and the curves:
  the session is replayed a second time with that model.

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
from snrmon.acquisition.prediction import (
    CURVES,
    EXPECTED_CURVES,
    NOISE_SOURCES,
    ModelPredictor,
    session_model_options,
)
from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.replay.batch import ReplayResult, replay_session
from snrmon.acquisition.replay.stop_noise import StopNoise, stop_noise
from snrmon.acquisition.report.stop_csv import csv_rows
from snrmon.acquisition.stops.detector import summarise_stop
from snrmon.acquisition.stops.table import StopRow, StopTable
from snrmon.model.atmosphere_table import Weather

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
class FlightResults:
    """What the flight measured: the stop rows, each row's Fig. 6 series, each camera's Figs.
    7-10 points, and the 3D noise of each stop's background (from a file)."""

    rows: list[StopRow]
    series: list[StopSeries]
    points: dict[str, MeasuredPoints]
    noise_3d: list[StopNoise] = field(default_factory=list)  # per stop and camera


@dataclass(frozen=True)
class ModelResults:
    """What the model gives for the session's sensors and target: each camera's curves (Figs.
    7-10), its uncertainty budget at its stops' ranges (Fig. 12), the table of the paper's
    reference values and each camera's detection summary."""

    curves: dict[str, ModelCurves]
    budgets: dict[str, list[BudgetAtRange]]
    references: list = field(default_factory=list)  # comparison.Reference
    detections: dict = field(default_factory=dict)  # camera -> comparison.DetectionSummary


@dataclass(frozen=True)
class ReportData:
    """The report (module docstring): the session and the model's inputs it was made with, what
    the flight measured, what the model gives, and the two compared (fits, CSV rows)."""

    path: Path
    target: str
    sensors: dict[str, str]
    flight: FlightResults
    model: ModelResults
    csv_rows: list[dict[str, object]]
    replay_seconds: float | None  # None: measured live, not replayed
    recording_seconds: float
    fits: list = field(default_factory=list)  # comparison.FitStatistic per camera and curve
    weather: Weather | None = None  # the met readings the model's curves used
    # camera -> model.noise.MeasuredNoise the model's values used; empty: the model's own noise
    measured_noise: dict = field(default_factory=dict)


def session_weather(path: str | Path) -> tuple[Weather | None, Weather | None]:
    """(the met readings the session started with: its ``[weather]`` table, the last ones it
    recorded: its last ``met_readings`` event, else the first); None where there are none."""
    from snrmon.acquisition.prediction import weather_from_record

    with open_session(path) as f:
        raw = f.config.get("session") if isinstance(f.config, dict) else None
        events = [e for e in f.event_list() if e["kind"] == "met_readings"]
    first = session_config_from_dict(raw).weather if raw else None
    last = weather_from_record(events[-1]["payload"]) if events else first
    return first, last


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
    lo = bisect.bisect_left(cam.t_host_ns, row.place.t_start_ns)
    hi = (
        len(cam.t_host_ns)
        if row.place.t_end_ns is None
        else bisect.bisect_left(cam.t_host_ns, row.place.t_end_ns)
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
        complete=row.reading.complete,
        t_s=(times - row.place.t_start_ns) / 1e9,
        peak=arr("peak"),
        bg_mean=arr("bg_mean"),
        bg_std=arr("bg_std"),
        snr=arr("snr"),
    )


def measured_points(rows: list[StopRow], camera: str) -> MeasuredPoints:
    keep = [
        r for r in rows if r.camera == camera and r.range_m is not None and r.reading.n_frames > 0
    ]
    return MeasuredPoints(
        camera=camera,
        stop=np.array([r.stop for r in keep], dtype=int),
        range_m=np.array([r.range_m for r in keep], dtype=float),
        snr_mean=np.array([r.reading.snr_mean for r in keep], dtype=float),
        snr_std=np.array([r.reading.snr_std for r in keep], dtype=float),
        snr_sem=np.array([r.reading.snr_sem for r in keep], dtype=float),
        n_frames=np.array([r.reading.n_frames for r in keep], dtype=int),
        complete=np.array([r.reading.complete for r in keep], dtype=bool),
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
    temps = [
        r.model.model_sky_temp_k for r in rows if r.camera == camera and r.model.model_sky_temp_k
    ]
    return float(np.median(temps)) if temps else None


def rows_psf(rows: list[StopRow], camera: str):
    """The corrected PSF to draw ``camera``'s curves with: the one its last stop row's model
    values were computed with (a PSF measured from the flight, once the console adopted one),
    so the curves are those the rows are compared with; None (the sensor preset's) without."""
    psfs = [r.model.model_psf for r in rows if r.camera == camera and r.model.model_psf is not None]
    return psfs[-1] if psfs else None


def uncertainty_budget(
    camera: str,
    sensor_name: str,
    target_name: str,
    ranges_m: list[float],
    *,
    background_temp_k: float | None = None,
    atmosphere=None,
) -> list[BudgetAtRange]:
    """Fig. 12 terms at each range for the small dimension, with the model's default budget,
    at the sky ``background_temp_k`` (None: assumed equal to the air, with its wider path
    term) through ``atmosphere`` (e.g. the session's met readings).

    The path-radiance term is the budget's fraction times L_bg / (L_t - L_bg) (section 9's
    amplification); the model exposes that factor through a budget holding only that term at
    1; the transmission term is the budget's fraction of the band's optical depth; so every
    number here is the model's own."""
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
        optical_depth=0.0,
        path_radiance=1.0,
        sky_assumed_k=0.0,
        mtf=0.0,
        target_size_blur=0.0,
    )
    extra = {} if atmosphere is None else {"atmosphere": atmosphere}
    p = predict(
        sensor,
        target,
        r,
        uncertainty=unit_path,
        background_temp_k=background_temp_k,
        band=False,
        expected=False,
        **extra,
    )
    unresolved = ~np.asarray(p.resolved_small, bool)
    od = -np.log(np.clip(np.asarray(p.transmission_contrast, float), 1e-300, 1.0))
    sky_per_k = None
    if p.sky_assumed:  # the path term is then the assumed sky's error, not 5 % of a measured one
        at_one_k = predict(
            sensor,
            target,
            r,
            uncertainty=UncertaintyBudget.only(sky_assumed_k=1.0),
            band=False,
            expected=False,
            **extra,
        )
        amp = np.asarray(at_one_k.relative_uncertainty["small_corrected"], float)
        sky_per_k = 1.0
    else:
        amp = np.asarray(p.relative_uncertainty["small_corrected"], float)
    terms = budget.terms(amp, unresolved, od, sky_per_k)
    total = budget.relative(amp, unresolved, od, sky_per_k)
    return [
        BudgetAtRange(
            camera,
            float(rng),
            not unresolved[i],
            {name: float(v[i]) for name, v in terms.items()},
            float(total[i]),
            budget.combine,
        )
        for i, rng in enumerate(r)
    ]


def stops_noise(path: str | Path, replay: ReplayResult, n: int = 100) -> list[StopNoise]:
    """The 3D noise of every stop row's background (module docstring), from the replay's
    measurements and the file's frames; rows without a valid frame or a clear region left out."""
    out = []
    with open_session(path) as f:
        times = {name: c.t_host_ns for name, c in replay.cameras.items()}
        for row in replay.stops:
            cam, rec = replay.cameras.get(row.camera), f.cameras.get(row.camera)
            if cam is None or rec is None:
                continue
            t = times[row.camera]
            lo = bisect.bisect_left(t, row.place.t_start_ns)
            hi = len(t) if row.place.t_end_ns is None else bisect.bisect_left(t, row.place.t_end_ns)
            ms = cam.tally.measurements[lo:hi]
            got = stop_noise(rec, row.stop, row.range_m, [m.result for m in ms], t[lo:hi], n=n)
            if got is not None:
                out.append(got)
    return out


def camera_noise(table: list[StopNoise]) -> dict[str, dict[str, float]]:
    """Per camera, the root mean square over its stops of each bias-corrected figure (DN)."""
    from snrmon.acquisition.measure.noise3d import pooled

    cameras = dict.fromkeys(s.camera for s in table)
    return {c: pooled(s.noise for s in table if s.camera == c) for c in cameras}


def measured_noise(table: list[StopNoise], cameras) -> dict:
    """{camera: model.noise.MeasuredNoise} from :func:`camera_noise`; a camera none of whose
    stops has a clear background is bad input (ValueError naming it)."""
    from snrmon.model.noise import MeasuredNoise

    pooled = camera_noise(table)
    missing = [c for c in cameras if c not in pooled]
    if missing:
        raise ValueError(
            f"measured noise: no stop of camera {missing[0]!r} has a background clear of the "
            "target to measure (the model's noise is needed)"
        )
    return {c: MeasuredNoise(pooled[c]["tvh"], pooled[c]["vh"]) for c in cameras}


def report_data(
    path: str | Path,
    *,
    target: str | None = None,
    frames_per_stop: int = 100,
    progress: Callable[[int, int], None] | None = None,
    noise: str = "model",
) -> ReportData:
    """Replay the session (every frame through the live measurement) and compute the report;
    ``noise`` "measured" replays it again with the cameras' measured noise in the model."""
    if noise not in NOISE_SOURCES:
        raise ValueError(f"noise must be one of {', '.join(NOISE_SOURCES)}, got {noise!r}")
    path = Path(path)
    sensors, target_name = session_models(path, target)
    first, last = session_weather(path)
    # the model starts from the session's [weather]; the replay applies the met readings the
    # session recorded at the times it recorded them; the figures use the last ones
    predictor = ModelPredictor(sensors, target_name, **session_model_options(first))
    replay = replay_session(path, predictor=predictor, progress=progress)
    table = stops_noise(path, replay, frames_per_stop)
    measured = {}
    if noise == "measured":
        measured = measured_noise(table, sensors)
        predictor = ModelPredictor(sensors, target_name, measured_noise=measured)
        replay = replay_session(path, predictor=predictor, progress=progress)
    rows = replay.stops
    with open_session(path) as f:
        clock = f.clock
    return assemble_report(
        path,
        sensors,
        target_name,
        rows,
        [stop_series(replay, r, frames_per_stop) for r in rows],
        seconds=replay.recording_seconds,
        replay_seconds=replay.seconds,
        weather=last,
        noise_3d=table,
        measured_noise=measured,
        clock=clock,
    )


def utc_text(clock: np.ndarray) -> Callable[[int], str]:
    """A host monotonic time (ns) -> its UTC through the session's ``clock`` rows, as ISO 8601
    text to the nanosecond (the CSV's stop times)."""
    from snrmon.acquisition.record.gps_align import host_to_utc_ns

    def text(t_host_ns: int) -> str:
        utc_ns = int(host_to_utc_ns(np.array([t_host_ns], np.int64), clock)[0])
        return f"{np.datetime64(utc_ns, 'ns')}Z"

    return text


def live_report_data(
    table: StopTable,
    sensors: dict[str, str],
    target: str,
    *,
    name: str,
    seconds: float,
    weather: Weather | None = None,
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
    return assemble_report(
        Path(name), sensors, target, rows, series, seconds=seconds, weather=weather
    )


def assemble_report(
    path: Path,
    sensors: dict[str, str],
    target: str,
    rows: list[StopRow],
    series: list[StopSeries],
    *,
    seconds: float,
    replay_seconds: float | None = None,
    weather: Weather | None = None,
    noise_3d: list[StopNoise] | None = None,
    measured_noise: dict | None = None,
    clock: np.ndarray | None = None,
) -> ReportData:
    """Figs. 7-10 and 12 and the CSV for measured stop rows: the model at the sensors' presets
    and the target, through the session's met readings ``weather`` (None: the model's default
    atmosphere) and with each camera's ``measured_noise`` where given, over a range grid that
    holds every stop; the CSV's stop times in UTC through the session's ``clock`` rows (None:
    a session in memory, the times left empty)."""
    measured = dict(measured_noise or {})
    stop_ranges = [r.range_m for r in rows if r.range_m is not None]
    grid = model_range_grid(stop_ranges)
    cameras = list(dict.fromkeys([*sensors, *(r.camera for r in rows)]))
    budgets = {}
    for c in cameras:
        ranges = sorted({r.range_m for r in rows if r.camera == c and r.range_m is not None})
        budgets[c] = uncertainty_budget(
            c,
            sensors[c],
            target,
            ranges,
            background_temp_k=rows_sky_k(rows, c),
            atmosphere=weather,
        )
    from snrmon.acquisition.report.comparison import (
        detection_summary,
        fit_statistics,
        reference_table,
    )

    models = {}
    for c in cameras:
        psf = rows_psf(rows, c)
        extra = {} if psf is None else {"corrected_psf": psf}
        if weather is not None:
            extra["atmosphere"] = weather
        if c in measured:
            extra["measured_noise"] = measured[c]
        models[c] = model_curves(
            c, sensors[c], target, grid, background_temp_k=rows_sky_k(rows, c), **extra
        )
    return ReportData(
        path=path,
        target=target,
        sensors=sensors,
        flight=FlightResults(
            rows=rows,
            series=series,
            points={c: measured_points(rows, c) for c in cameras},
            noise_3d=list(noise_3d or []),
        ),
        model=ModelResults(
            curves=models,
            budgets=budgets,
            references=reference_table(sensors, target),
            detections={
                c: detection_summary(
                    c, sensors[c], target, **({} if weather is None else {"atmosphere": weather})
                )
                for c in cameras
            },
        ),
        csv_rows=csv_rows(rows, None if clock is None else utc_text(clock)),
        replay_seconds=replay_seconds,
        recording_seconds=seconds,
        fits=fit_statistics(rows, models),
        weather=weather,
        measured_noise=measured,
    )
