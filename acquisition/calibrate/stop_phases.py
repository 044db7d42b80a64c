"""The expected Eq. (4) reading of one stop over the sub-pixel phases its own frames sampled (paper
Eqs. (1)-(4), sections 5 and 7).

The model's expected reading at a range (``model.eq4.expected_eq4``, the curves of
:mod:`snrmon.acquisition.prediction`) is a mean over sub-pixel phases uniform over the pixel:
what many stops read on average. One stop's 100 frames of a hover (1.7 s of MWIR, 3.3 s of LWIR)
sample only the few phases the drone drifted through, and a PSF near the diffraction limit (the
LWIR's, section 8) puts a share of the light on the peak pixel that changes with the phase
(``model.footprint.pixel_patterns`` with the PSF fitted on the simulated day, at 451 m: 0.59
with the drone on the pixel's centre, 0.19 on its corner; the MWIR's 0.146 and 0.105). A stop
row's measured mean is therefore held to the reading expected over its own frames k = 1..N:

    E_stop = (1/N) sum_k R(A, phi_k),
    R(A, phi) = (E[max_i (a_i(phi) + z_i)] - mean_rim a(phi)) x E[sigma / s_rim]

with A the model's total contrast signal over the temporal noise (Eqs. (1)-(3)), a_i(phi) = A x
the energy of the PSF convolved with the drone's square on the active area of pixel i when the
drone's centroid lies phi = (dx, dy) from the peak pixel's centre, z_i unit normal noise, and
the Eq. (4) estimator's rim and sample std as ``model.eq4`` states them (``expected_eq4(...,
phases_xy=...)``: the same expectation, over these phases instead of the uniform cell; each
folded into the half cell and binned to 1/24 px). The phases are measured from the same frames:
``psf_estimate.observed_phases`` matches each frame's 7 x 7 pixels around its peak with the
patterns of the PSF the row's curves use on a grid of offsets 1/12 px apart (a per-frame
least-squares position). Against the twin's true centroids on the simulated days
(``tools/stop_phase_truth.py``, seeds 5 and 6) the folded offsets are off by a median
0.022-0.032 px, and the LWIR's lie up to 0.022 px nearer the pixel's centre on average (per
axis; its fitted blur is 0.16 px, the twin's 0.10): the reading over them is 1.5-2.5 % above the
one over the true phases there, the MWIR's within 0.5 %. (The tracker's core centroid is not
kept with a measurement; the fit's offsets are of the frames' own pixels.)

Where these come from (``tools/psf_fit_footprint.py``: the twin's own drone through its own
optics at known uniform phases, unit noise, fitted and measured as the console does; drone
light 100 x the noise). The median error is mostly the offsets' 1/12-px grid: a uniform error
over +-1/24 px has a median of 1/48 = 0.021 px, and the twin's crops give 0.025-0.031. The
LWIR's wide blur is the fit's target, a square of the small dimension: the twin's quadcopter
silhouette of the same area spreads its light wider, which matters where the drone is not
small against the LWIR's near-diffraction-limited PSF. The day's first unresolved LWIR stop
(199 m, 0.78 px) alone fits a blur of 0.170 px (``--sizes 0.78``), the four beyond it (0.46-0.30
px) 0.091, all five pooled 0.117 (the MWIR's four, 0.93-0.62 px, 0.588 against the twin's
0.57: its PSF is wide against the drone). Phases measured with a blur too wide lean toward the
pixel's centre: at 0.34-0.46 px the mean folded error per axis is -0.001 to +0.007 px with the
twin's 0.10, -0.009 to +0.001 with 0.13 and -0.006 to -0.015 with 0.16 (``--sizes
0.46,0.39,0.34 --blur B``): the LWIR's lean on the days is the lean of its wide fitted blur.
The 199-m stop is not the only source of that blur: the same three stops flown two ways at
1.5 x (``tools/stop_phase_truth.py 5 --stops 336,393,451 --size 256x192 --speed 1.5``, the
default flight from 10 m at 8 m/s with 7-s hovers; and with ``--transit-mps 30 --start-m 300
--hover-s 6``, the flight of ``tests/test_hil_psf.py``) fit an LWIR blur of 0.14-0.15 px and
0.100-0.105 px, their offsets lean -0.007 to -0.014 px and -0.004 to +0.008 px, and the reading
over them is 1.9-2.0 % above the one over the true phases and within 0.2 % of it (MWIR, blur
0.59-0.60, within 0.5 % both ways). What in the first flight's frames widens the fitted blur
was not found (the twin's rendered crops at uniform phases do not: the sizes of those stops
alone fit 0.09; the phases a stop's drift samples are not uniform).
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable, Mapping, Sequence
from concurrent.futures import Future

import numpy as np

from snrmon.acquisition.calibrate.flight_psf import MIN_FRAMES, FlightPsf
from snrmon.acquisition.calibrate.psf_estimate import StopCrops, observed_phases, target_px
from snrmon.acquisition.prediction import AT_STOP, EXPECTED_CURVES

log = logging.getLogger(__name__)

CropsAt = Callable[[str, Sequence[int]], np.ndarray]
Submit = Callable[..., Future]


def stop_expected_readings(
    crops: np.ndarray, drone_px: float, sensor, target, range_m: float, options: Mapping
) -> dict[str, float]:
    """``{expected_eq4_<rule>_stop: E_stop}`` (module docstring) of a stop's frames ``crops``
    (N, 13, 13, each centred on its peak pixel), the drone ``drone_px`` across at ``range_m``,
    with the model's ``options`` in force (:meth:`ModelPredictor.options_in_force`, its
    ``corrected_psf`` the fitted PSF the phases are measured with)."""
    from snrmon.model.snr import predict

    psf = options["corrected_psf"]
    phases = observed_phases(StopCrops("stop", crops, drone_px), psf, sensor.fill_factor)
    p = predict(sensor, target, [range_m], **{**options, "band": False, "phases_xy": phases})
    return {f"{name}{AT_STOP}": float(p.snr(name)[0]) for name in EXPECTED_CURVES}


def with_band(values: Mapping[str, float], cell: Mapping[str, float]) -> dict[str, float]:
    """``values`` (:func:`stop_expected_readings`) and each one's band: the cell reading's
    ``cell[<rule>_lower/_upper]`` times the stop's reading over the cell's."""
    out = dict(values)
    for name in EXPECTED_CURVES:
        at_stop, over_cell = values.get(f"{name}{AT_STOP}"), cell.get(name)
        if at_stop is None or over_cell is None or not (math.isfinite(over_cell) and over_cell > 0):
            continue
        for edge in ("lower", "upper"):
            if f"{name}_{edge}" in cell:
                out[f"{name}{AT_STOP}_{edge}"] = cell[f"{name}_{edge}"] * at_stop / over_cell
    return out


def _run_key(run) -> tuple:
    """What identifies a row's run: its length and its first and last frames' times."""
    return (len(run), run[0][0], run[-1][0]) if run else (0,)


class StopPhaseReadings:
    """Each final stop row's expected readings over its frames' phases (module docstring), as
    the stop table's ``stop_model``. ``engine`` is the session's (its predictor);
    ``crops_at(camera, times_ns)`` the logged crops of those frames
    (:meth:`snrmon.acquisition.calibrate.flight_psf.FlightPsf.crops_at`); ``submit`` runs a
    computation for an asynchronous predictor (default: the worker process)."""

    def __init__(self, engine, crops_at: CropsAt, *, submit: Submit | None = None) -> None:
        self.engine = engine
        self._crops_at = crops_at
        self._submit = submit
        self._lock = threading.Lock()
        # (stop, camera) -> ((the camera's curves, the run) the job was made for, the job)
        self._jobs: dict[tuple[int, str], tuple[tuple, Future]] = {}

    def stop_model(
        self, stop: int, camera: str, range_m: float | None, run, *, wait: bool = False
    ) -> dict[str, float] | None:
        """The row ``(stop, camera)``'s readings over its frames' phases (``run``: the table's
        (t_host_ns, PeakSnr) of the row) with their band: {} where none is made (module
        docstring), None while they are being computed (unless ``wait``). Made once per run
        and curves while the stop is open (asked again, an open row shown while the drone
        hovers, it gives the same), and again once the stop has ended, or the row is made final
        at the session's end (``wait``: the stop table's ``finalize``), if its range is no
        longer the one they were made at: the open stop's range is the median of its readings
        so far, so the final row's reading is made at the final row's range (as a replay, which
        applies the ended stop or the stop open at the end, makes it)."""
        predictor = self.engine.predictor
        if predictor is None or range_m is None:
            return {}
        # made for these curves, these frames (a stop's end known late can shorten a run) and,
        # once the stop has ended, its range
        made_for = (getattr(predictor, "curves", {}).get(camera), _run_key(run), float(range_m))
        key = (stop, camera)
        with self._lock:
            held = self._jobs.get(key)
        if (
            held is None
            or held[0][0] is not made_for[0]
            or held[0][1] != made_for[1]
            or (held[0][2] != made_for[2] and (wait or self._ended(stop)))
        ):
            args = self._inputs(predictor, camera, float(range_m), run)
            if args is None:
                return {}
            held = (made_for, self._start(predictor, args))
            with self._lock:
                self._jobs[key] = held
        job = held[1]
        if not (wait or job.done()):
            return None
        if job.cancelled():  # dropped by the worker at exit: the row keeps the cell's reading
            return {}
        try:
            values = job.result()
        except Exception:  # the row keeps the cell's reading alone
            log.exception("stop %d (%s): the expected reading at its phases failed", stop, camera)
            return {}
        return with_band(values, predictor(camera, float(range_m)))

    def _ended(self, stop: int) -> bool:
        """Whether stop ``stop`` of the engine's stop source has ended (its range is final)."""
        stops = self.engine.stop_source.stops
        return 0 <= stop < len(stops) and stops[stop].t_end_ns is not None

    def _inputs(self, predictor, camera: str, range_m: float, run) -> tuple | None:
        """The arguments of :func:`stop_expected_readings` for the row, None where no reading
        over its phases is made (module docstring)."""
        sensor = getattr(predictor, "sensors", {}).get(camera)
        options_in_force = getattr(predictor, "options_in_force", None)
        if sensor is None or options_in_force is None or predictor.curves_psf.get(camera) is None:
            return None
        drone_px = target_px(predictor.target, range_m, sensor.ifov_rad)
        if drone_px >= 1.0:
            return None
        crops = self._crops_at(camera, [t for t, _ in run])
        if len(crops) < MIN_FRAMES:
            return None
        return crops, drone_px, sensor, predictor.target, range_m, options_in_force(camera)

    def _start(self, predictor, args: tuple) -> Future:
        if self._submit is None and not getattr(predictor, "asynchronous", False):
            job: Future = Future()
            try:
                job.set_result(stop_expected_readings(*args))
            except Exception as exc:  # reported where the row takes it (stop_model)
                job.set_exception(exc)
            return job
        submit = self._submit
        if submit is None:
            from snrmon.acquisition import worker_process

            submit = worker_process.submit
        return submit(stop_expected_readings, *args)


def stop_phase_readings(engine, flight_psf: FlightPsf) -> StopPhaseReadings:
    """The readings over each final row's phases (:class:`StopPhaseReadings`) made the stop
    table's ``stop_model`` of ``engine`` (a session's, live or replayed), from the crops that
    ``flight_psf`` logs of the engine's measured frames (it is made the engine's listener)."""
    engine.add_listener(flight_psf.on_measurement)
    readings = StopPhaseReadings(engine, flight_psf.crops_at)
    engine.stop_table.stop_model = readings.stop_model
    return readings
