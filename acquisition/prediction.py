"""The model's prediction at a measured range, for the stop table and the live charts.

The four curves of paper Figs. 7-10 (small/large characteristic dimension, uncorrected
diffraction-limited / corrected real PSF, both with the drone as a square of its dimension:
continuous through the resolved/unresolved transition), the expected Eq. (4) readings on the
corrected small target (``expected_eq4_rim``: the paper's estimator, background the 7x7 box's
24-pixel rim; ``expected_eq4_extent``: the console's target-aware background) and the
paper's own switched curves are computed once per camera on a dense logarithmic range grid by
:func:`snrmon.model.snr.predict` and interpolated in log-range, so a lookup per frame costs
microseconds and every number still comes from :mod:`snrmon.model`.

The day's met readings (:class:`Weather`: air temperature, humidity, pressure, visibility; from
the session's ``[weather]`` table, :func:`session_model_options`, or typed in the console,
:meth:`ModelPredictor.set_weather`, which a session records as a ``met_readings`` event and a
replay applies at the same time) drive the model's LOWTRAN7 atmosphere. The operator's "measured
noise" (:class:`MeasuredNoise`, a camera's 3D noise: :meth:`ModelPredictor.set_measured_noise`,
recorded as a ``model_noise`` event) replaces the model's noise the same way.

A recomputation (a new sky temperature, a PSF measured from the flight, new met readings) takes
~30-70 ms per camera once the process has computed one (the model keeps the PSF's tables and
patterns), ~0.1 s the first time (``snrmon bench --only model``).
With ``asynchronous=True`` :meth:`ModelPredictor.set_background` returns at once and the new
curves replace the old ones, whole, when they are ready: the session calls it from a camera's
measurement thread. They are computed in the worker process
(:mod:`snrmon.acquisition.worker_process`), not in a thread: the computation holds the interpreter
lock, which the measurement threads need.
"""

from __future__ import annotations

import logging
import threading
from collections.abc import Callable
from concurrent.futures import Future
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import numpy as np

from snrmon.model.atmosphere_table import AEROSOLS, DEFAULT_VISIBILITY_KM, SEASONS, Weather
from snrmon.model.noise import MeasuredNoise

__all__ = [
    "AEROSOLS",
    "DEFAULT_VISIBILITY_KM",
    "NOISE_SOURCES",
    "SEASONS",
    "MeasuredNoise",
    "ModelPredictor",
    "ModelRequest",
    "Weather",
    "config_predictor",
    "session_model_options",
]

log = logging.getLogger(__name__)

CURVES = ("small", "large", "small_corrected", "large_corrected")
EXPECTED_RIM = "expected_eq4_rim"
EXPECTED_EXTENT = "expected_eq4_extent"
EXPECTED_CURVES = (EXPECTED_RIM, EXPECTED_EXTENT)
"""The expected Eq. (4) readings by background rule (``model.snr.EXPECTED_CURVES``)."""
PAPER_CURVES = tuple(f"paper_{c}" for c in CURVES)
BANDED_CURVES = ("small_corrected", "large_corrected", *EXPECTED_CURVES)
"""The curves the model gives a band of (paper section 9: the corrected ones and the readings)."""
AT_STOP = "_stop"
"""The suffix of an expected reading over the sub-pixel phases of one stop's own frames
(``expected_eq4_rim_stop``, its band ``expected_eq4_rim_stop_lower``...;
``acquisition.calibrate.stop_phases``), beside the same reading over the whole cell."""
STOP_EXPECTED_CURVES = tuple(f"{name}{AT_STOP}" for name in EXPECTED_CURVES)
STOP_MODEL_KEYS: tuple[str, ...] = (
    *CURVES,
    *EXPECTED_CURVES,
    *(f"{name}_{edge}" for name in BANDED_CURVES for edge in ("lower", "upper")),
    *(f"{name}{suffix}" for name in STOP_EXPECTED_CURVES for suffix in ("", "_lower", "_upper")),
)
"""The model's values a stop row can carry (:meth:`ModelPredictor.__call__`, and the expected
readings over the stop's own phases, :data:`AT_STOP`), in table order."""
NOISE_SOURCES = ("model", "measured")
"""The model's noise: its own (Eq. 1 and the spatial term), or the camera's measured 3D noise."""


def session_model_options(config) -> dict:
    """The :func:`snrmon.model.snr.predict` options a session's configuration (or its
    :class:`Weather` itself) sets: the ``[weather]`` met readings as the atmosphere (nothing
    without them) and its ``footprint`` (nothing for the paper's square)."""
    weather = config if isinstance(config, Weather) else getattr(config, "weather", None)
    out: dict = {} if weather is None else {"atmosphere": weather}
    footprint = getattr(config, "footprint", "square")
    if footprint != "square":
        out["footprint"] = footprint
    return out


@dataclass(frozen=True)
class ModelRequest:
    """The model an operator asks a session for (the console's model options): the target, the
    background temperature (None: the model's own), the day's met readings (None: the default
    atmosphere) and, per camera, a measured 3D noise in place of the model's. A command: the
    session's engine builds the predictors from it (:meth:`predictors`, applied by
    ``SessionEngine.set_model``); a display only reads them."""

    target: str
    background_temp_k: float | None = None
    weather: Weather | None = None
    measured_noise: tuple[tuple[str, MeasuredNoise], ...] = ()

    def predictor(
        self, sensors: dict[str, str], *, footprint: str = "square", asynchronous: bool = False
    ) -> ModelPredictor:
        """The predictor of the request for ``sensors`` ({camera: sensor preset}), with the
        session's ``footprint`` (what the request does not change) and ``asynchronous`` as
        :func:`config_predictor` takes it; a ValueError for a request the model refuses (an
        unknown target)."""
        options = session_model_options(self.weather)
        if footprint != "square":
            options["footprint"] = footprint
        return ModelPredictor(
            sensors,
            self.target,
            background_temp_k=self.background_temp_k,
            measured_noise=dict(self.measured_noise),
            asynchronous=asynchronous,
            **options,
        )


def config_predictor(config, *, asynchronous: bool = False) -> ModelPredictor | None:
    """The model a session's config names (a :class:`SessionConfig`, live or recorded): its
    cameras' sensor presets, its target, its ``[weather]`` and footprint
    (:func:`session_model_options`); None when it names no camera. ``asynchronous``: a new
    sky's curves are computed in the worker process, beside the measurement threads."""
    if not config.cameras:
        return None
    return ModelPredictor(
        {c.name: c.sensor for c in config.cameras},
        config.target,
        asynchronous=asynchronous,
        **session_model_options(config),
    )


def weather_from_record(payload: dict) -> Weather:
    """The :class:`Weather` of a recorded ``met_readings`` event (``Weather.as_dict``)."""
    return Weather.from_dict(dict(payload))


def measured_noise_record(noise: MeasuredNoise | None) -> dict:
    """The payload of a ``model_noise`` event: ``temporal_dn`` (sigma_tvh) and ``spatial_dn``
    (sigma_vh), or {} for the model's own noise."""
    if noise is None:
        return {}
    return {"temporal_dn": float(noise.temporal_dn), "spatial_dn": float(noise.spatial_dn)}


def measured_noise_from_record(payload: dict) -> MeasuredNoise | None:
    """The :class:`MeasuredNoise` of a recorded ``model_noise`` event (None: {}, the model's
    own noise); ValueError naming what is wrong with a damaged one."""
    if not payload:
        return None
    try:
        return MeasuredNoise(float(payload["temporal_dn"]), float(payload["spatial_dn"]))
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"model_noise event {dict(payload)!r}: {exc}") from None


@runtime_checkable
class Predictor(Protocol):
    """What the pipeline asks of the model (:class:`ModelPredictor` is the implementation): the
    prediction at a range, the curves for plotting, and the two inputs a session changes while
    it runs (the measured sky temperature, a PSF measured from the flight)."""

    version: int
    """Counts the curves swapped in: a display redraws when it changes."""
    background_temp_k: dict[str, float | None]
    """The background (sky) temperature asked for, per camera (None: the model's own)."""

    @property
    def curves_background_k(self) -> dict[str, float]:
        """The background temperature the current curves were computed for, per camera (K)."""
        ...

    @property
    def curves_psf(self) -> dict[str, Any]:
        """The corrected PSF the current curves were computed with, per camera (None: the
        preset's)."""
        ...

    @property
    def curves_psf_source(self) -> dict[str, str]:
        """Which PSF that is, in words for the console (:func:`psf_source`), per camera."""
        ...

    def __call__(self, camera: str, range_m: float) -> dict[str, float]:
        """The curves at ``range_m`` (``CURVES``, ``EXPECTED_CURVES``, ``resolved_small``, and
        the model's uncertainty band of a curve as ``<curve>_lower`` / ``<curve>_upper`` where it
        has one); empty when the camera has no curves or the range is not positive."""
        ...

    def curve(self, camera: str) -> dict[str, tuple]:
        """The curves over the range grid, for plotting (see :meth:`ModelPredictor.curve`)."""
        ...

    def set_background(
        self, camera: str, temp_k: float | None, *, wait: bool | None = None
    ) -> None: ...

    def set_psf(self, camera: str, psf: Any, *, wait: bool | None = None) -> None: ...

    def pending(self, camera: str) -> bool:
        """True while curves for ``camera``'s latest inputs are still being computed."""
        ...

    def set_weather(
        self, weather: Weather | None, camera: str | None = None, *, wait: bool | None = None
    ) -> None:
        """The day's met readings for ``camera``'s atmosphere (every camera's when None; None
        readings: the model's own)."""
        ...

    def set_measured_noise(
        self, camera: str, noise: MeasuredNoise | None, *, wait: bool | None = None
    ) -> None:
        """``camera``'s measured 3D noise in place of the model's (None: the model's own)."""
        ...


def psf_source(sensor, psf) -> str:
    """Which PSF a prediction's corrected curves used, in words (paper sections 5 and 8): the
    sensor preset's (``psf`` None: ``Sensor.corrected_psf_source``, e.g. "preset: PVF 0.082
    (sensor mwir)"), or one measured from the flight's unresolved stops ("fitted: sigma 0.59 px
    from this flight's stops", its Gaussian blur)."""
    if psf is None:
        return str(sensor.corrected_psf_source)
    sigma = getattr(psf, "sigma_px", None)
    if sigma is None:
        return "fitted: from this flight's stops"
    return f"fitted: sigma {float(sigma):.2f} px from this flight's stops"


def psf_label(source: str | None) -> str | None:
    """:func:`psf_source`'s words as a display's short mark: "preset PSF" or "fitted PSF" (the
    word before its colon); None without a source (no model)."""
    if not source:
        return None
    return f"{source.split(':', 1)[0]} PSF"


@dataclass(frozen=True)
class CurvesInForce:
    """One camera's current curves and what they were computed for, swapped in together (a
    reader never sees the curves of one request with the sky or PSF of another)."""

    curves: dict[str, np.ndarray]
    background_k: float  # the background temperature used (K; the model's own if none asked)
    psf: object  # the corrected PSF used (None: the sensor preset's)
    psf_source: str  # that PSF in words (:func:`psf_source`)


class Recomputations:
    """The bookkeeping of the curves' computations, per camera: each request's generation (a
    result is swapped in only if no newer request superseded it) and how many run in the
    background (:meth:`ModelPredictor.pending`). Thread-safe: results arrive on the worker
    pool's thread."""

    def __init__(self) -> None:
        self._lock = threading.Lock()
        self._generation: dict[str, int] = {}
        self._running: dict[str, int] = {}

    def next_generation(self, camera: str) -> int:
        """A new request for ``camera``'s curves: its generation."""
        with self._lock:
            gen = self._generation.get(camera, 0) + 1
            self._generation[camera] = gen
            return gen

    def started(self, camera: str) -> None:
        with self._lock:
            self._running[camera] = self._running.get(camera, 0) + 1

    def finished(self, camera: str) -> None:
        with self._lock:
            self._running[camera] -= 1

    def pending(self, camera: str) -> bool:
        """True while a background computation of ``camera``'s curves is under way."""
        with self._lock:
            return self._running.get(camera, 0) > 0

    def if_latest(self, camera: str, gen: int, swap: Callable[[], None]) -> None:
        """``swap()`` under the lock, unless a newer request than ``gen`` superseded it."""
        with self._lock:
            if self._generation[camera] == gen:
                swap()


class ModelPredictor:
    """``predictor(camera, range_m) -> {"small", "large", "small_corrected",
    "large_corrected", "expected_eq4_rim", "expected_eq4_extent", "resolved_small"}`` (and the
    band of the corrected curves and the expected readings, ``<curve>_lower`` /
    ``<curve>_upper``) for each camera's sensor preset and one target. ``predict_options`` go
    to :func:`snrmon.model.snr.predict` (``background_temp_k``, ``air_temp_k``, ``atmosphere``,
    ``corrected_psf``...). ``measured_noise``: per camera, its measured 3D noise
    (:class:`snrmon.model.noise.MeasuredNoise`) in place of the model's noise (the operator's
    "measured noise"); a camera not in it keeps the model's."""

    def __init__(
        self,
        sensors: dict[str, str],
        target: str,
        *,
        ranges_m: np.ndarray | None = None,
        asynchronous: bool = False,
        measured_noise: dict | None = None,
        **predict_options,
    ) -> None:
        from snrmon.model.presets import load_sensor, load_target
        from snrmon.model.snr import predict

        self.target = load_target(target)
        self._predict = predict
        self._options = dict(predict_options)
        self.measured_noise = dict(measured_noise or {})
        self.asynchronous = asynchronous
        self.sensors = {}
        self.background_temp_k: dict[str, float | None] = {}
        self.psf: dict[str, object] = {}
        # The met readings each camera's curves are (being) computed for (None: the options')
        default_weather = predict_options.get("atmosphere")
        if not isinstance(default_weather, Weather):
            default_weather = None
        self.weather: dict[str, Weather | None] = {c: default_weather for c in sensors}
        self.ranges_m = (
            np.geomspace(10.0, 5000.0, 600) if ranges_m is None else np.asarray(ranges_m, float)
        )
        self._log_r = np.log(self.ranges_m)
        # swapped whole (no half reads), so a stop row names the curves its values came from
        self._in_force: dict[str, CurvesInForce] = {}
        self._recomputations = Recomputations()
        self.version = 0  # counts the curves swapped in: a display redraws when it changes
        for camera, sensor_name in sensors.items():
            self.sensors[camera] = load_sensor(sensor_name)
            self._compute(camera, predict_options.get("background_temp_k"), None)
        if asynchronous:
            from snrmon.acquisition import worker_process

            worker_process.start()  # its imports now, not at the first new sky

    def set_background(self, camera: str, temp_k: float | None, *, wait: bool | None = None):
        """Recompute ``camera``'s curves for a measured background (sky) temperature: the
        paper's path-radiance correction (sections 8-9); None returns to the model's own."""
        if camera in self.sensors:
            self._schedule(camera, temp_k, self.psf.get(camera), wait)

    def set_psf(self, camera: str, psf, *, wait: bool | None = None) -> None:
        """Use ``psf`` (a ``model.psf`` PSF, e.g. measured from the flight,
        ``acquisition.calibrate.psf_estimate``) for ``camera``'s corrected curves; None returns
        to the sensor preset's."""
        if camera in self.sensors:
            self._schedule(camera, self.background_temp_k.get(camera), psf, wait)

    def set_weather(
        self, weather: Weather | None, camera: str | None = None, *, wait: bool | None = None
    ) -> None:
        """Use the day's met readings ``weather`` for ``camera``'s curves (every camera's when
        None); the same readings again recompute nothing."""
        for cam in [camera] if camera is not None else list(self.sensors):
            if cam not in self.sensors or self.weather.get(cam) == weather:
                continue
            self.weather[cam] = weather
            self._schedule(cam, self.background_temp_k.get(cam), self.psf.get(cam), wait)

    def set_measured_noise(
        self, camera: str, noise: MeasuredNoise | None, *, wait: bool | None = None
    ) -> None:
        """Use ``camera``'s measured 3D noise ``noise`` in place of the model's noise (the
        operator's "measured noise"; None: back to the model's own); the same noise again
        recomputes nothing."""
        if camera not in self.sensors or self.measured_noise.get(camera) == noise:
            return
        others = {c: n for c, n in self.measured_noise.items() if c != camera}
        # replaced whole: another thread (a session's measurement thread) may be reading it
        self.measured_noise = others if noise is None else {**others, camera: noise}
        self._schedule(camera, self.background_temp_k.get(camera), self.psf.get(camera), wait)

    def pending(self, camera: str) -> bool:
        """True while a computation of ``camera``'s curves is under way (in the background)."""
        return self._recomputations.pending(camera)

    @property
    def curves(self) -> dict[str, dict[str, np.ndarray]]:
        """Each camera's current curves (:func:`curves_of`)."""
        return {c: f.curves for c, f in self._in_force.items()}

    @property
    def curves_background_k(self) -> dict[str, float]:
        """The background temperature each camera's current curves were computed for (K; the
        model's own when none was asked for)."""
        return {c: f.background_k for c, f in self._in_force.items()}

    @property
    def curves_psf(self) -> dict[str, object]:
        """The corrected PSF each camera's current curves were computed with (None: the sensor
        preset's)."""
        return {c: f.psf for c, f in self._in_force.items()}

    @property
    def curves_psf_source(self) -> dict[str, str]:
        """Which PSF that is, in words (:func:`psf_source`), per camera."""
        return {c: f.psf_source for c, f in self._in_force.items()}

    def _schedule(self, camera, temp_k, psf, wait) -> None:
        # the inputs are current at once (a second request for the same value does nothing)
        self.background_temp_k[camera] = temp_k
        self.psf[camera] = psf
        if wait if wait is not None else not self.asynchronous:
            self._compute(camera, temp_k, psf)
            return
        from snrmon.acquisition import worker_process

        gen = self._recomputations.next_generation(camera)
        self._recomputations.started(camera)
        try:
            job = worker_process.submit(
                model_curves,
                self.sensors[camera],
                self.target,
                self.ranges_m,
                self._options_for(camera, temp_k, psf),
            )
        except BaseException:
            self._recomputations.finished(camera)
            raise

        def done(job: Future) -> None:  # on the worker pool's thread
            if job.cancelled():  # dropped at exit: nobody will read it
                self._recomputations.finished(camera)
                return
            try:
                curves, used_k = job.result()
            except Exception:  # a failed recomputation keeps the curves in force
                log.exception("%s: the model's recomputation failed", camera)
                return
            finally:
                self._recomputations.finished(camera)
            self._swap(camera, gen, temp_k, psf, curves, used_k)

        job.add_done_callback(done)

    def options_in_force(self, camera: str) -> dict:
        """The :func:`snrmon.model.snr.predict` options of ``camera``'s latest inputs (those of
        its current curves once :meth:`pending` is False): to compute more of the model with
        exactly the inputs its curves had (``acquisition.calibrate.stop_phases``)."""
        return self._options_for(camera, self.background_temp_k.get(camera), self.psf.get(camera))

    def _options_for(self, camera: str, background_temp_k: float | None, psf) -> dict:
        options = {**self._options, "background_temp_k": background_temp_k}
        weather = self.weather.get(camera)
        if weather is not None:
            options["atmosphere"] = weather
        if camera in self.measured_noise:
            options["measured_noise"] = self.measured_noise[camera]
        if psf is not None:
            options["corrected_psf"] = psf
        return options

    def _compute(self, camera: str, background_temp_k: float | None, psf) -> None:
        gen = self._recomputations.next_generation(camera)
        options = self._options_for(camera, background_temp_k, psf)
        p = self._predict(self.sensors[camera], self.target, self.ranges_m, **options)
        self._swap(camera, gen, background_temp_k, psf, curves_of(p), p.background_temp_k)

    def _swap(self, camera, gen: int, background_temp_k, psf, curves: dict, used_k: float) -> None:
        in_force = CurvesInForce(curves, used_k, psf, psf_source(self.sensors[camera], psf))

        def swap() -> None:
            self.background_temp_k[camera] = used_k if background_temp_k else None
            self._in_force = {**self._in_force, camera: in_force}  # swapped whole
            self.version += 1

        self._recomputations.if_latest(camera, gen, swap)

    def __call__(self, camera: str, range_m: float) -> dict[str, float]:
        in_force = self._in_force.get(camera)
        if in_force is None or range_m is None or not range_m > 0:
            return {}
        curves = in_force.curves
        x = np.log(range_m)
        names = [*CURVES, *(n for n in EXPECTED_CURVES if n in curves)]
        out = {name: float(np.interp(x, self._log_r, curves[name])) for name in names}
        for name in names:  # the model's uncertainty band at this range (paper section 9)
            for edge in ("lower", "upper"):
                if f"{name}_{edge}" in curves:
                    out[f"{name}_{edge}"] = float(
                        np.interp(x, self._log_r, curves[f"{name}_{edge}"])
                    )
        # the paper's resolved/unresolved verdict (D >= 1 px) is a step, not interpolated
        i = int(np.clip(np.searchsorted(self._log_r, x), 0, len(self._log_r) - 1))
        out["resolved_small"] = float(curves["resolved_small"][i])
        return out

    def curve(self, camera: str) -> dict[str, tuple]:
        """The curves of ``camera`` as (ranges_m, snr) pairs, for plotting: the four, the
        expected Eq. (4) readings of both rules and the paper's four (``paper_<name>``); and the
        band of the corrected curves and the expected readings as (ranges_m, lower, upper)."""
        in_force = self._in_force.get(camera)
        c = in_force.curves if in_force is not None else {}
        names = (*CURVES, *EXPECTED_CURVES, *PAPER_CURVES)
        out: dict[str, tuple] = {name: (self.ranges_m, c[name]) for name in names if name in c}
        for name in BANDED_CURVES:
            if f"{name}_lower" in c:
                out[f"{name} band"] = (self.ranges_m, c[f"{name}_lower"], c[f"{name}_upper"])
        return out


def curves_of(p) -> dict[str, np.ndarray]:
    """The curves a :class:`ModelPredictor` keeps of a ``snrmon.model.snr.predict`` result."""
    curves = {name: np.asarray(snr, float) for name, snr in p.curves().items()}
    curves["resolved_small"] = np.asarray(p.resolved_small, float)
    return curves


def model_curves(sensor, target, ranges_m: np.ndarray, options: dict) -> tuple[dict, float]:
    """(:func:`curves_of` the model's prediction, the background temperature it used, K): a
    recomputation as the worker process runs it (small to send back, unlike the prediction)."""
    from snrmon.model.snr import predict

    p = predict(sensor, target, ranges_m, **options)
    return curves_of(p), float(p.background_temp_k)
