"""The expected Eq. (4) readings of ``predict`` over a long range grid (computed at nodes along
it, from cached patterns, and interpolated: model/snr.py) against the same readings computed
directly at each range, with every cache emptied first.

Tolerance 0.5 %: at close range the console's target rule steps by up to 0.4 % where a pixel
joins the drone's 3-sigma extent (the direct computation has these steps; the curve steps over
them), and the interpolation elsewhere is within 0.25 % (docs/model.md, measured on 18 cases).
The interpolated curve before this was off by up to 160 % (7x7 rim) and 18 % (target rule)
on a linear range grid."""

import numpy as np
import pytest

from snrmon.model.eq4 import expected_eq4_by_rule
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.psf import AiryGaussianPsf
from snrmon.model.snr import EXPECTED_CURVES, clear_caches, predict

TOLERANCE = 0.005
UAV1 = load_target("uav1")


def _direct(sensor, psf, ranges_m, background_temp_k):
    """Each range's reading from the model's own amplitude and size there, nothing cached."""
    p = predict(
        sensor,
        UAV1,
        ranges_m,
        corrected_psf=psf,
        background_temp_k=background_temp_k,
        expected=False,
        band=False,
    )
    amplitude = np.clip(p.point_contrast_e["small"] / p.noise.total, 0.0, None)
    d_px = UAV1.size_m("small") / (ranges_m * sensor.ifov_rad)
    clear_caches()
    return expected_eq4_by_rule(psf, sensor.fill_factor, amplitude, target_square_px=d_px)


@pytest.mark.parametrize("camera", ["mwir", "lwir"])
@pytest.mark.parametrize("measured_psf", [False, True])
def test_fast_expected_readings_are_the_direct_ones_within_half_a_percent(camera, measured_psf):
    sensor = load_sensor(camera)
    # a PSF measured from a flight is the camera's Airy blurred by the fitted Gaussian
    # (acquisition.calibrate.psf_estimate)
    psf = AiryGaussianPsf(sensor.diffraction_psf(), 0.45) if measured_psf else None
    psf = psf or sensor.corrected_psf()
    grid = np.geomspace(10.0, 5000.0, 600)  # the console's
    clear_caches()
    predict(sensor, UAV1, grid, corrected_psf=psf, band=False)  # the caches of another sky
    fast = predict(sensor, UAV1, grid, corrected_psf=psf, background_temp_k=270.0, band=False)
    # close range (the drone 15-30 px wide), the transitions, long range
    picks = np.array([3, 40, 90, 140, 190, 240, 300, 360, 420, 480, 540, 597])
    direct = _direct(sensor, psf, grid[picks], 270.0)
    for name, rule in EXPECTED_CURVES.items():
        assert fast.snr(name)[picks] == pytest.approx(direct[rule], rel=TOLERANCE), name


@pytest.mark.parametrize("camera", ["mwir", "lwir"])
def test_on_a_linear_range_grid_too(camera):
    """The bench's grid, 20-3000 m in equal steps: nodes follow ln(range), not the index."""
    sensor = load_sensor(camera)
    psf = sensor.corrected_psf()
    grid = np.linspace(20.0, 3000.0, 500)
    fast = predict(sensor, UAV1, grid, band=False)
    picks = np.array([2, 7, 13, 25, 40, 70, 130, 250, 499])  # 32-3000 m; 62 m was 88 % off
    direct = _direct(sensor, psf, grid[picks], None)
    for name, rule in EXPECTED_CURVES.items():
        assert fast.snr(name)[picks] == pytest.approx(direct[rule], rel=TOLERANCE), name


@pytest.mark.parametrize("camera", ["mwir", "lwir"])
def test_a_prediction_does_not_depend_on_what_ran_before(camera):
    """The caches hold patterns and readings that depend on their own inputs alone: the same
    prediction after others (other skies, another grid) is the one a fresh process makes."""
    sensor = load_sensor(camera)
    grid = np.geomspace(10.0, 5000.0, 600)
    clear_caches()
    fresh = predict(sensor, UAV1, grid, background_temp_k=275.0)
    clear_caches()
    predict(sensor, UAV1, np.linspace(20.0, 3000.0, 500))
    predict(sensor, UAV1, grid, background_temp_k=250.0, band=False)
    again = predict(sensor, UAV1, grid, background_temp_k=275.0)
    for name in (*EXPECTED_CURVES, "small_corrected"):
        assert np.array_equal(again.snr(name), fresh.snr(name)), name
        assert np.array_equal(again.lower[name], fresh.lower[name]), name


@pytest.mark.parametrize("camera", ["mwir", "lwir"])
def test_a_new_sky_reads_what_a_fresh_process_reads(camera):
    """What is kept across skies on a grid (the path's transmission, the band's sky-free
    draws, the patterns and their peak candidates and extent shapes, the first nodes) gives
    the prediction of a new sky bit for bit as computed from nothing."""
    sensor = load_sensor(camera)
    grid = np.linspace(20.0, 3000.0, 500)
    clear_caches()
    predict(sensor, UAV1, grid, background_temp_k=262.0)
    kept = predict(sensor, UAV1, grid, background_temp_k=281.0)
    clear_caches()
    fresh = predict(sensor, UAV1, grid, background_temp_k=281.0)
    for name in (*EXPECTED_CURVES, "small_corrected", "large_corrected"):
        assert np.array_equal(kept.snr(name), fresh.snr(name)), name
        assert np.array_equal(kept.lower[name], fresh.lower[name]), name
        assert np.array_equal(kept.upper[name], fresh.upper[name]), name
