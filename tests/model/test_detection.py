"""Probability of detection versus range and the detection range with its confidence."""

import numpy as np
import pytest
from scipy.special import ndtr

from snrmon.model.detection import detection, threshold_sigma
from snrmon.model.footprint import phase_grid, pixel_patterns
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.snr import predict

MW, UAV1 = load_sensor("mwir"), load_target("uav1")


def test_threshold_from_the_false_alarm_rate():
    # one false alarm per hour over 1280 x 720 pixels at 60 Hz: p = 3e-13 per pixel
    k = threshold_sigma(1.0, 1280 * 720, 60.0)
    assert 1.0 - ndtr(k) == pytest.approx(1.0 / 3600 / 60 / (1280 * 720), rel=1e-6)
    assert threshold_sigma(3600.0, 100, 1.0) < k
    with pytest.raises(ValueError, match="false-alarm rate"):
        threshold_sigma(0.0, 100, 1.0)


def test_pd_falls_with_range_through_the_goal_at_the_detection_range():
    ranges = np.geomspace(200.0, 3000.0, 120)
    d = detection(MW, UAV1, ranges)
    assert np.all(np.diff(d.pd) <= 1e-12) and d.pd[0] > 0.99 and d.pd[-1] < 0.01
    assert d.range_lower_m < d.range_m < d.range_upper_m
    assert np.all(d.pd_lower <= d.pd + 1e-12) and np.all(d.pd <= d.pd_upper + 1e-12)
    # Pd at the detection range, recomputed by hand over the phases: the goal
    r = d.range_m
    p = predict(MW, UAV1, [r], expected=False, band=False)
    ph = phase_grid(5)
    pats = pixel_patterns(
        MW.corrected_psf(), 0.8, ph, ph, target_square_px=UAV1.small_m / (r * MW.ifov_rad)
    )
    a = p.point_contrast_e["small"][0] / p.noise.total * pats.reshape(25, -1)
    pd = np.mean(1.0 - np.prod(ndtr(d.threshold_sigma - a), axis=1))
    assert pd == pytest.approx(0.5, abs=0.02)
    # a stricter false-alarm rate shortens it
    strict = detection(MW, UAV1, ranges, false_alarms_per_hour=1e-3)
    assert strict.range_m < d.range_m
