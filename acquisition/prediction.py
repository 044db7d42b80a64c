"""The model's prediction at a measured range, for the stop table and the live charts.

The four curves of paper Figs. 7-10 (small/large characteristic dimension, uncorrected
diffraction-limited / corrected real PSF, both with the drone as a square of its dimension:
continuous through the resolved/unresolved transition), the expected Eq. (4) reading
(``expected_eq4``: what the 7x7 estimator should read on the corrected small target) and the
paper's own switched curves are computed once per camera on a dense logarithmic range grid by
:func:`snrmon.model.snr.predict` and interpolated in log-range, so a lookup per frame costs
microseconds and every number still comes from :mod:`snrmon.model`.

A recomputation (a new sky temperature, a PSF measured from the flight) takes ~0.5 s per camera.
With ``asynchronous=True`` :meth:`ModelPredictor.set_background` returns at once and the new
curves replace the old ones, whole, when they are ready: the session calls it from a camera's
measurement thread. They are computed in the worker process
(:mod:`snrmon.acquisition.worker_process`), not in a thread: the computation holds the interpreter
lock, which the measurement threads need.
"""

from __future__ import annotations

import logging
import threading
from concurrent.futures import Future
from typing import Any, Protocol, runtime_checkable

import numpy as np

log = logging.getLogger(__name__)

CURVES = ("small", "large", "small_corrected", "large_corrected")
EXPECTED = "expected_eq4"
PAPER_CURVES = tuple(f"paper_{c}" for c in CURVES)


@runtime_checkable
class Predictor(Protocol):
    """What the pipeline asks of the model (:class:`ModelPredictor` is the implementation): the
    prediction at a range, the curves for plotting, and the two inputs a session changes while
    it runs (the measured sky temperature, a PSF measured from the flight)."""

    version: int
    """Counts the curves swapped in: a display redraws when it changes."""
    background_temp_k: dict[str, float | None]
    """The background (sky) temperature asked for, per camera (None: the model's own)."""
    curves_background_k: dict[str, float]
    """The background temperature the current curves were computed for, per camera (K)."""
    curves_psf: dict[str, Any]
    """The corrected PSF the current curves were computed with, per camera (None: preset's)."""

    def __call__(self, camera: str, range_m: float) -> dict[str, float]:
        """The curves at ``range_m`` (``CURVES``, ``EXPECTED``, ``resolved_small``); empty
        when the camera has no curves or the range is not positive."""
        ...

    def curve(self, camera: str) -> dict[str, tuple]:
        """The curves over the range grid, for plotting (see :meth:`ModelPredictor.curve`)."""
        ...

    def set_background(
        self, camera: str, temp_k: float | None, *, wait: bool | None = None
    ) -> None: ...

    def set_psf(self, camera: str, psf: Any, *, wait: bool | None = None) -> None: ...


class ModelPredictor:
    """``predictor(camera, range_m) -> {"small", "large", "small_corrected",
    "large_corrected", "expected_eq4", "resolved_small"}`` for each camera's sensor preset and
    one target. ``predict_options`` go to :func:`snrmon.model.snr.predict` (``background_temp_k``,
    ``air_temp_k``, ``atmosphere``, ``corrected_psf``...)."""

    def __init__(
        self,
        sensors: dict[str, str],
        target: str,
        *,
        ranges_m: np.ndarray | None = None,
        asynchronous: bool = False,
        **predict_options,
    ) -> None:
        from snrmon.model.presets import load_sensor, load_target
        from snrmon.model.snr import predict

        self.target = load_target(target)
        self._predict = predict
        self._options = dict(predict_options)
        self.asynchronous = asynchronous
        self.sensors = {}
        self.background_temp_k: dict[str, float | None] = {}
        # The background temperature the current curves were computed for (K; the model's own
        # when none was asked for), swapped in with them.
        self.curves_background_k: dict[str, float] = {}
        # The corrected PSF the current curves were computed with (None: the sensor preset's),
        # swapped in with them, so a stop row names the curves its values came from.
        self.curves_psf: dict[str, object] = {}
        self.psf: dict[str, object] = {}
        self.ranges_m = (
            np.geomspace(10.0, 5000.0, 600) if ranges_m is None else np.asarray(ranges_m, float)
        )
        self._log_r = np.log(self.ranges_m)
        self.curves: dict[str, dict[str, np.ndarray]] = {}
        self._lock = threading.Lock()
        self._generation: dict[str, int] = {}
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

    def _schedule(self, camera, temp_k, psf, wait) -> None:
        # the inputs are current at once (a second request for the same value does nothing)
        self.background_temp_k[camera] = temp_k
        self.psf[camera] = psf
        if wait if wait is not None else not self.asynchronous:
            self._compute(camera, temp_k, psf)
            return
        from snrmon.acquisition import worker_process

        gen = self._next_generation(camera)
        job = worker_process.submit(
            model_curves,
            self.sensors[camera],
            self.target,
            self.ranges_m,
            self._options_for(temp_k, psf),
        )

        def done(job: Future) -> None:  # on the worker pool's thread
            try:
                curves, used_k = job.result()
            except Exception:  # a failed recomputation keeps the curves in force
                log.exception("%s: the model's recomputation failed", camera)
                return
            self._swap(camera, gen, temp_k, psf, curves, used_k)

        job.add_done_callback(done)

    def _next_generation(self, camera: str) -> int:
        with self._lock:
            gen = self._generation.get(camera, 0) + 1
            self._generation[camera] = gen
            return gen

    def _options_for(self, background_temp_k: float | None, psf) -> dict:
        options = {**self._options, "background_temp_k": background_temp_k}
        if psf is not None:
            options["corrected_psf"] = psf
        return options

    def _compute(self, camera: str, background_temp_k: float | None, psf) -> None:
        gen = self._next_generation(camera)
        options = self._options_for(background_temp_k, psf)
        p = self._predict(self.sensors[camera], self.target, self.ranges_m, **options)
        self._swap(camera, gen, background_temp_k, psf, curves_of(p), p.background_temp_k)

    def _swap(self, camera, gen: int, background_temp_k, psf, curves: dict, used_k: float) -> None:
        with self._lock:
            if self._generation[camera] != gen:
                return  # a newer request superseded this one
            self.background_temp_k[camera] = used_k if background_temp_k else None
            self.curves = {**self.curves, camera: curves}  # swapped whole: no half reads
            self.curves_background_k = {**self.curves_background_k, camera: used_k}
            self.curves_psf = {**self.curves_psf, camera: psf}
            self.version += 1

    def __call__(self, camera: str, range_m: float) -> dict[str, float]:
        curves = self.curves.get(camera)
        if curves is None or range_m is None or not range_m > 0:
            return {}
        x = np.log(range_m)
        names = [*CURVES, EXPECTED] if EXPECTED in curves else list(CURVES)
        out = {name: float(np.interp(x, self._log_r, curves[name])) for name in names}
        # the paper's resolved/unresolved verdict (D >= 1 px) is a step, not interpolated
        i = int(np.clip(np.searchsorted(self._log_r, x), 0, len(self._log_r) - 1))
        out["resolved_small"] = float(curves["resolved_small"][i])
        return out

    def curve(self, camera: str) -> dict[str, tuple]:
        """The curves of ``camera`` as (ranges_m, snr) pairs, for plotting: the four, the
        expected Eq. (4) reading and the paper's four (``paper_<name>``); and the band of the
        corrected curves and the expected reading as (ranges_m, lower, upper)."""
        c = self.curves.get(camera, {})
        names = (*CURVES, EXPECTED, *PAPER_CURVES)
        out: dict[str, tuple] = {name: (self.ranges_m, c[name]) for name in names if name in c}
        for name in ("small_corrected", "large_corrected", EXPECTED):
            if f"{name}_lower" in c:
                out[f"{name} band"] = (self.ranges_m, c[f"{name}_lower"], c[f"{name}_upper"])
        return out


def curves_of(p) -> dict[str, np.ndarray]:
    """The curves a :class:`ModelPredictor` keeps of a ``snrmon.model.snr.predict`` result."""
    curves = {
        "small": np.asarray(p.snr_small, float),
        "large": np.asarray(p.snr_large, float),
        "small_corrected": np.asarray(p.snr_small_corrected, float),
        "large_corrected": np.asarray(p.snr_large_corrected, float),
        "resolved_small": np.asarray(p.resolved_small, float),
    }
    if p.expected_eq4 is not None:
        curves[EXPECTED] = np.asarray(p.expected_eq4, float)
    for name, snr in p.paper.items():
        curves[f"paper_{name}"] = np.asarray(snr, float)
    for name in ("small_corrected", "large_corrected", EXPECTED):  # the band
        if name in p.lower and name in p.upper:
            curves[f"{name}_lower"] = np.asarray(p.lower[name], float)
            curves[f"{name}_upper"] = np.asarray(p.upper[name], float)
    return curves


def model_curves(sensor, target, ranges_m: np.ndarray, options: dict) -> tuple[dict, float]:
    """(:func:`curves_of` the model's prediction, the background temperature it used, K): a
    recomputation as the worker process runs it (small to send back, unlike the prediction)."""
    from snrmon.model.snr import predict

    p = predict(sensor, target, ranges_m, **options)
    return curves_of(p), float(p.background_temp_k)
