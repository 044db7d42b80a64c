"""A stop's expected Eq. (4) reading over the sub-pixel phases its own frames sampled
(acquisition/calibrate/stop_phases.py), against a reference written here from the paper: the
drone's square through a Gaussian PSF integrated over each pixel's active area by brute force
(midpoint sums, no closed form), and the Eq. (4) estimator run on noisy frames at the TRUE
phases; the stop's reading measures its phases from the frames' own crops."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snrmon.acquisition.calibrate.stop_phases import (
    StopPhaseReadings,
    stop_expected_readings,
    with_band,
)
from snrmon.acquisition.stops.detector import Stop
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.psf import GaussianPsf
from snrmon.model.snr import predict

SIGMA_PX = 0.35  # about the LWIR's Gaussian fit on the simulated day: the phase matters most
HALF = 10  # frames of 21 x 21 px: the 11 x 11 search, its 7 x 7 box and a 13 x 13 crop fit


def _pixel_shares_1d(phase_px: float, d_px: float, fill_factor: float) -> np.ndarray:
    """(2 HALF + 1,) share of a 1-D box of width ``d_px`` centred at ``phase_px``, blurred by
    the Gaussian, on the active interval (width sqrt(FF)) of pixels -HALF..HALF: the double
    integral over the box and the interval as midpoint sums (400 x 400 points)."""
    m = 400
    box = phase_px + d_px * ((np.arange(m) + 0.5) / m - 0.5)  # the drone's point sources
    a = math.sqrt(fill_factor)
    out = np.empty(2 * HALF + 1)
    for i, centre in enumerate(range(-HALF, HALF + 1)):
        x = centre + a * ((np.arange(m) + 0.5) / m - 0.5)  # the active interval
        density = np.exp(-0.5 * ((x[:, None] - box[None, :]) / SIGMA_PX) ** 2)
        out[i] = density.mean() * a / (SIGMA_PX * math.sqrt(2.0 * math.pi))
    return out


def _pattern(dx: float, dy: float, d_px: float, fill_factor: float) -> np.ndarray:
    """(21, 21) energy on each pixel's active area, the drone's centroid (dx, dy) from the
    middle pixel's centre (the square and the Gaussian are separable in x and y)."""
    return np.outer(
        _pixel_shares_1d(dy, d_px, fill_factor), _pixel_shares_1d(dx, d_px, fill_factor)
    )


def _eq4(frames: np.ndarray) -> np.ndarray:
    """Paper Eq. (4) per frame: the brightest pixel of the 11 x 11 search window around the
    frame's middle, less the mean of the 24 rim pixels of the 7 x 7 box around it, over their
    sample std (ddof 1)."""
    n = len(frames)
    search = frames[:, HALF - 5 : HALF + 6, HALF - 5 : HALF + 6].reshape(n, -1)
    r, c = np.divmod(np.argmax(search, axis=1), 11)
    r, c = r + HALF - 5, c + HALF - 5
    k = np.arange(-3, 4)
    ring = np.maximum(np.abs(k)[:, None], np.abs(k)[None, :]) == 3
    dy, dx = np.nonzero(ring)
    rim = frames[np.arange(n)[:, None], r[:, None] + dy - 3, c[:, None] + dx - 3]
    peak = frames[np.arange(n), r, c]
    return (peak - rim.mean(axis=1)) / rim.std(axis=1, ddof=1)


def _hover_phases(n: int, seed: int) -> np.ndarray:
    """(n, 2) centroid offsets of a slow drift near a pixel's centre (a hover that stayed on
    one pixel: where the peak pixel holds the most light and the cell average reads low)."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / n
    drift = np.stack([0.05 + 0.12 * np.sin(2.0 * t + 0.3), -0.08 + 0.1 * np.cos(3.0 * t)], axis=1)
    return drift + 0.01 * rng.standard_normal((n, 2))


@pytest.mark.slow
def test_a_stops_reading_follows_the_estimator_at_the_phases_its_frames_had():
    sensor = load_sensor("lwir")
    target = load_target("uav1")
    range_m = 451.0
    options = {"corrected_psf": GaussianPsf(SIGMA_PX), "band": False}
    p = predict(sensor, target, [range_m], **options)
    amplitude = float(p.point_contrast_e["small"][0] / p.noise.total)  # Eqs. (1)-(3)
    d_px = target.small_m / (range_m * sensor.ifov_rad)
    assert d_px < 1.0 and 10.0 < amplitude * 0.3 < 60.0  # unresolved, an LWIR far stop's SNR

    phases = _hover_phases(100, seed=11)
    rng = np.random.default_rng(12)
    patterns = np.stack([_pattern(x, y, d_px, sensor.fill_factor) for x, y in phases])
    # the stop: one noisy frame per phase (unit noise on a pedestal), cropped 13 x 13 around
    # its measured peak as the console logs it
    frames = 500.0 + amplitude * patterns + rng.standard_normal(patterns.shape)
    crops = []
    for f in frames:
        r, c = np.unravel_index(
            int(np.argmax(f[HALF - 5 : HALF + 6, HALF - 5 : HALF + 6])), (11, 11)
        )
        r, c = r + HALF - 5, c + HALF - 5
        crops.append(f[r - 6 : r + 7, c - 6 : c + 7])
    got = stop_expected_readings(np.stack(crops), d_px, sensor, target, range_m, options)

    # the reference: Eq. (4) on 300 noisy draws of each of the stop's true patterns
    draws = amplitude * np.repeat(patterns, 300, axis=0)
    draws = draws + rng.standard_normal(draws.shape)
    reference = float(np.mean(_eq4(draws)))
    cell = float(p.snr("expected_eq4_rim")[0])

    assert got["expected_eq4_rim_stop"] == pytest.approx(reference, rel=0.02)
    assert reference > 1.08 * cell  # near a pixel's centre: the cell average is > 8 % low
    # inside the 5x5 guard the console's own background is the 7x7 rim: the same reading
    assert got["expected_eq4_extent_stop"] == pytest.approx(got["expected_eq4_rim_stop"], rel=1e-3)


def test_the_stops_band_is_the_cells_scaled_to_its_reading():
    cell = {
        "expected_eq4_rim": 20.0,
        "expected_eq4_rim_lower": 16.0,
        "expected_eq4_rim_upper": 25.0,
        "expected_eq4_extent": 0.0,  # no reading to scale by: no band
    }
    got = with_band({"expected_eq4_rim_stop": 22.0, "expected_eq4_extent_stop": 21.0}, cell)
    assert got["expected_eq4_rim_stop_lower"] == pytest.approx(17.6)
    assert got["expected_eq4_rim_stop_upper"] == pytest.approx(27.5)
    assert "expected_eq4_extent_stop_lower" not in got


class _Stops:
    """A stop source: the stops as the stop table reads them."""

    def __init__(self) -> None:
        self.stops: list[Stop] = []


class _Engine:
    def __init__(self, predictor) -> None:
        self.predictor = predictor
        self.stop_source = _Stops()


def test_a_stops_reading_is_made_once_for_a_fitted_psf_at_an_unresolved_stop():
    """Nothing for the preset's PSF or a resolved stop; with a fitted PSF one computation per
    run and curves (asked again, the same), a new one when the curves are replaced."""
    from concurrent.futures import Future

    from snrmon.acquisition.prediction import ModelPredictor

    predictor = ModelPredictor({"lwir": "lwir"}, "uav1", band=False)
    jobs = []

    def submit(fn, *args):
        jobs.append(args)
        job: Future = Future()
        job.set_result({"expected_eq4_rim_stop": 30.0, "expected_eq4_extent_stop": 30.0})
        return job

    readings = StopPhaseReadings(
        _Engine(predictor), lambda camera, times: np.zeros((len(times), 13, 13)), submit=submit
    )
    run = [(t, None) for t in range(100)]
    assert readings.stop_model(3, "lwir", 451.0, run) == {}  # the preset's PSF
    predictor.set_psf("lwir", GaussianPsf(SIGMA_PX))
    assert readings.stop_model(0, "lwir", 37.0, run) == {}  # resolved: 4 px
    assert readings.stop_model(3, "lwir", 451.0, run[:49]) == {}  # too few frames
    got = readings.stop_model(3, "lwir", 451.0, run)
    assert got["expected_eq4_rim_stop"] == 30.0 and len(jobs) == 1
    crops, drone_px, _, _, range_m, options = jobs[0]
    assert crops.shape == (100, 13, 13) and drone_px < 1.0 and range_m == 451.0
    assert options["corrected_psf"] == GaussianPsf(SIGMA_PX)
    assert readings.stop_model(3, "lwir", 451.0, run) == got and len(jobs) == 1
    predictor.set_psf("lwir", GaussianPsf(0.4))
    readings.stop_model(3, "lwir", 451.0, run)
    assert len(jobs) == 2 and jobs[1][5]["corrected_psf"] == GaussianPsf(0.4)


def test_a_job_the_worker_dropped_leaves_the_cells_reading():
    """A computation cancelled (the worker's pool closing at exit) gives {} quietly: the row is
    final with the cell's reading, not held."""
    from concurrent.futures import Future

    from snrmon.acquisition.prediction import ModelPredictor

    predictor = ModelPredictor({"lwir": "lwir"}, "uav1", band=False)
    predictor.set_psf("lwir", GaussianPsf(SIGMA_PX))

    def submit(fn, *args):
        job: Future = Future()
        job.cancel()
        return job

    readings = StopPhaseReadings(
        _Engine(predictor), lambda camera, times: np.zeros((len(times), 13, 13)), submit=submit
    )
    run = [(t, None) for t in range(100)]
    assert readings.stop_model(3, "lwir", 451.0, run) == {}
    assert readings.stop_model(3, "lwir", 451.0, run, wait=True) == {}


def test_an_ended_stops_reading_is_made_again_at_its_final_range():
    """While the stop is open its range moves with each reading: the open row keeps the reading
    made when its run was complete; made final (the stop ended, or open at the session's end)
    at another range, one more at the final range (the one a replay, which applies the recorded
    stop, makes), and no other after it."""
    from concurrent.futures import Future

    from snrmon.acquisition.prediction import ModelPredictor

    predictor = ModelPredictor({"lwir": "lwir"}, "uav1", band=False)
    predictor.set_psf("lwir", GaussianPsf(SIGMA_PX))
    jobs = []

    def submit(fn, *args):
        jobs.append(args)
        job: Future = Future()
        job.set_result({"expected_eq4_rim_stop": args[4] / 10, "expected_eq4_extent_stop": 1.0})
        return job

    engine = _Engine(predictor)
    readings = StopPhaseReadings(
        engine, lambda camera, times: np.zeros((len(times), 13, 13)), submit=submit
    )
    run = [(t, None) for t in range(100)]
    engine.stop_source.stops = [Stop(0, 0, None, 450.0, None, False)]
    assert readings.stop_model(0, "lwir", 450.0, run)["expected_eq4_rim_stop"] == 45.0
    assert readings.stop_model(0, "lwir", 450.2, run)["expected_eq4_rim_stop"] == 45.0
    assert len(jobs) == 1  # open: the first reading
    # the session ends with the stop open (the stop table's finalize waits): its range as it stands
    assert readings.stop_model(0, "lwir", 450.4, run, wait=True)["expected_eq4_rim_stop"] == 45.04
    assert len(jobs) == 2
    engine.stop_source.stops = [Stop(0, 0, 10, 451.0, None, False)]
    assert readings.stop_model(0, "lwir", 451.0, run)["expected_eq4_rim_stop"] == 45.1
    assert readings.stop_model(0, "lwir", 451.0, run, wait=True)["expected_eq4_rim_stop"] == 45.1
    assert [j[4] for j in jobs] == [450.0, 450.4, 451.0]
