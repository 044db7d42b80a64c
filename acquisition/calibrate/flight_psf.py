"""The camera's PSF fitted from the flight while it flies (paper sections 5, 7 and 8).

The sensor preset's corrected PSF is solved for the paper's average PVF (section 8), while the
paper's own Gaussian fit to its MWIR imagery (section 5, sigma 0.8 px) implies a wider one: the
two disagree by up to 1.8x in the predicted peak SNR at MWIR. The console therefore fits the PSF
to the flight's own frames (:mod:`snrmon.acquisition.calibrate.psf_estimate`) as soon as the
first unresolved stop's row is final, and fits it again, pooled over every unresolved stop so
far, each time another one is final; each fit replaces the model's corrected PSF for that camera
(:meth:`snrmon.acquisition.engine.session_engine.SessionEngine.adopt_psf`, recorded as a
``model_psf`` event, so a replay uses it from the same frame on). The rows frozen before a fit
was adopted keep the PSF they were computed with ("preset PSF"); the later ones say "fitted
PSF" (:func:`snrmon.acquisition.prediction.psf_source`).

:class:`CropLog` keeps, per camera, the 13 x 13 pixels around every valid measured peak
(non-uniformity corrected with the camera's calibration), so that a stop's frames can give the
PSF without a recording. A stop gives a PSF when its drone is unresolved (the small dimension
under 1 px at the stop's range, :func:`psf_estimate.check_stop`) and at least
:data:`MIN_FRAMES` of its frames are logged. The fit runs in the worker process
(:mod:`snrmon.acquisition.worker_process`, about a second of NumPy), away from the measurement
threads; a fit that cannot be made (:class:`psf_estimate.PsfEstimateError`) leaves the model's
PSF as it is.
"""

from __future__ import annotations

import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from concurrent.futures import Future
from typing import Any

import numpy as np

from snrmon.acquisition.calibrate.psf_estimate import (
    PsfEstimate,
    PsfEstimateError,
    StopCrops,
    crop_frames,
    estimate_psf,
    target_px,
)

log = logging.getLogger(__name__)

MIN_FRAMES = 50
"""Frames a stop must give for a fit (``psf_estimate.estimate_psf``'s ``min_frames``)."""
LOG_FRAMES = 4000
"""Crops kept per camera: a stop row is final within a few frames of its stop's end, and its
frames are its last 100 (the stop table's history is as long, ``HISTORY_FRAMES``)."""


class CropLog:
    """The last ``frames`` 13 x 13 crops around each valid measured peak of one camera:
    (t_host_ns, crop), the crop non-uniformity corrected by the calibration given with it."""

    def __init__(self, frames: int = LOG_FRAMES) -> None:
        self.crops: deque[tuple[int, np.ndarray]] = deque(maxlen=int(frames))

    def add(self, t_host_ns: int, pixels: np.ndarray, result, calibration=None) -> None:
        """Log the crop around ``result``'s peak (a ``PeakSnr``), corrected by ``calibration``
        (``acquisition.calibrate.calibration.Calibration``) if given, unless the frame is
        flagged, its SNR is not finite or the crop would leave the image."""
        if result is None or result.flags or not math.isfinite(result.snr):
            return
        crop = crop_frames([pixels], [(result.peak_x, result.peak_y)], calibration)
        if len(crop):
            self.crops.append((int(t_host_ns), crop[0]))

    def between(self, times_ns) -> np.ndarray:
        """The crops at exactly these frame times (a stop row's run), in order."""
        wanted = set(int(t) for t in times_ns)
        got = [c for t, c in list(self.crops) if t in wanted]
        return np.asarray(got).reshape(-1, 13, 13)


def stop_label(stop: int, camera: str) -> str:
    """A stop as messages name it: "stop 3 (mwir)"."""
    return f"stop {stop} ({camera})"


Submit = Callable[..., Future]


class FlightPsf:
    """The PSF of each camera fitted from its unresolved stops as they complete (module
    docstring). ``engine`` is the session's engine: its stop table, its predictor (whose
    sensors and target say which stops are unresolved; without one nothing is logged or fitted)
    and :meth:`adopt_psf`; ``calibration_of(camera)`` the calibration a camera's crops are
    corrected with now (None: none); ``adopt`` False logs the crops (for :meth:`stops`) without
    handing a fit to the model; ``submit`` runs a fit (default: the worker process)."""

    def __init__(
        self,
        engine,
        cameras,
        *,
        calibration_of: Callable[[str], Any] | None = None,
        adopt: bool = True,
        submit: Submit | None = None,
        frames: int = LOG_FRAMES,
    ) -> None:
        self.engine = engine
        self.adopt = adopt
        self._calibration_of = calibration_of or (lambda _camera: None)
        self._submit = submit
        self.logs = {c: CropLog(frames) for c in cameras}
        self._lock = threading.Lock()
        self._stops: dict[str, dict[int, StopCrops]] = {c: {} for c in self.logs}
        self._adopted: dict[str, int] = {}  # camera -> stops in the fit adopted last
        self.fits: dict[str, PsfEstimate] = {}  # camera -> the fit adopted last

    def on_measurement(self, m, pixels: np.ndarray | None) -> None:
        """A session measurement listener: log the frame's crop (nothing without a model)."""
        if pixels is None or m.camera not in self.logs or self.engine.predictor is None:
            return
        self.logs[m.camera].add(m.t_host_ns, pixels, m.result, self._calibration_of(m.camera))

    def crops_of(self, row) -> np.ndarray:
        """The logged crops of a stop row's frames (its run in the stop table), in order."""
        run = self.engine.stop_table.run_of(row.stop, row.camera)
        return self.crops_at(row.camera, [t for t, _ in run])

    def crops_at(self, camera: str, times_ns) -> np.ndarray:
        """The logged crops of ``camera``'s frames at ``times_ns`` (a stop row's run), in
        order; none for a camera without a log."""
        log_ = self.logs.get(camera)
        return np.zeros((0, 13, 13)) if log_ is None else log_.between(times_ns)

    def stops(self, camera: str) -> list[StopCrops]:
        """The unresolved stops of ``camera`` final so far, with their crops, in stop order."""
        with self._lock:
            return [s for _, s in sorted(self._stops.get(camera, {}).items())]

    def on_row_final(self, row) -> None:
        """A stop row is final: keep its crops if its drone is unresolved, and fit the PSF to
        all of the camera's unresolved stops so far (in the background)."""
        predictor = self.engine.predictor
        sensor = getattr(predictor, "sensors", {}).get(row.camera)
        rng = row.range_m
        if sensor is None or rng is None or row.camera not in self.logs:
            return
        d_px = target_px(predictor.target, rng, sensor.ifov_rad)
        crops = self.crops_of(row)
        if d_px >= 1.0 or len(crops) < MIN_FRAMES:
            return
        with self._lock:
            self._stops[row.camera][row.stop] = StopCrops(
                stop_label(row.stop, row.camera), crops, d_px
            )
            stops = [s for _, s in sorted(self._stops[row.camera].items())]
        if self.adopt:
            self._fit(row.camera, sensor, stops)

    def _fit(self, camera: str, sensor, stops: list[StopCrops]) -> None:
        submit = self._submit
        if submit is None:
            from snrmon.acquisition import worker_process

            submit = worker_process.submit
        n = len(stops)

        def done(job: Future) -> None:  # on the worker pool's thread
            if job.cancelled():  # dropped at exit: nobody will read it
                return
            try:
                est = job.result()
            except PsfEstimateError as exc:
                log.info("%s: no PSF from the flight yet: %s", camera, exc)
                return
            except Exception:
                log.exception("%s: the PSF fit failed", camera)
                return
            self._adopt(camera, est, n)

        submit(estimate_psf, stops, sensor, min_frames=MIN_FRAMES).add_done_callback(done)

    def _adopt(self, camera: str, est: PsfEstimate, n_stops: int) -> None:
        with self._lock:
            if n_stops < self._adopted.get(camera, 0):
                return  # a fit of fewer stops finished after one of more: keep the latter
            self._adopted[camera] = n_stops
            self.fits[camera] = est
        t = self.engine.model_input_ns(camera)
        self.engine.adopt_psf(camera, est.as_dict(), t if t is not None else time.monotonic_ns())
        log.info(
            "%s: PSF fitted from %d unresolved stop(s): sigma %.2f px, PVF %.3f",
            camera,
            n_stops,
            est.sigma_px,
            est.pvf,
        )
