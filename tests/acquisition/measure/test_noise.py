"""Section 6 noise analysis: total, temporal (scaled by 1/sqrt(2), and literal), spatial."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snrmon.acquisition.measure.noise import NoiseMeter, estimate_noise


def _frames(seed, temporal=6.6, spatial=15.0, shape=(240, 320)):
    rng = np.random.default_rng(seed)
    pattern = rng.normal(0.0, spatial, shape)  # fixed pattern: the same in both frames
    a = 3000 + pattern + rng.normal(0.0, temporal, shape)
    b = 3000 + pattern + rng.normal(0.0, temporal, shape)
    return np.rint(a).astype(np.uint16), np.rint(b).astype(np.uint16)


def test_temporal_spatial_and_total_recover_the_synthetic_truth():
    previous, frame = _frames(1)
    est = estimate_noise(frame, previous)
    assert est.total_dn == pytest.approx(math.hypot(6.6, 15.0), rel=0.02)
    assert est.temporal_dn == pytest.approx(6.6, rel=0.02)
    assert est.temporal_paper_dn == pytest.approx(6.6 * math.sqrt(2), rel=0.02)
    assert est.temporal_paper_dn == pytest.approx(est.temporal_dn * math.sqrt(2), rel=1e-15)
    assert est.spatial_dn == pytest.approx(15.0, rel=0.03)
    assert est.spatial_dn == pytest.approx(math.sqrt(est.total_dn**2 - est.temporal_dn**2))
    assert est.spatial_paper_dn < est.spatial_dn
    assert est.n_pixels == 240 * 320 and not est.detrended


def test_unsigned_frames_do_not_wrap_and_region_is_inclusive():
    previous = np.full((10, 10), 5, dtype=np.uint16)
    frame = previous.copy()
    frame[::2, :] = 7  # frame - previous is +2 or 0; wrapped uint16 would be 65534
    est = estimate_noise(previous, frame, region=(0, 0, 9, 1))
    assert est.n_pixels == 20
    assert est.temporal_paper_dn == pytest.approx(np.array([2.0] * 10 + [0.0] * 10).std(ddof=1))


def test_no_temporal_part_means_spatial_equals_total():
    frame = np.arange(100, dtype=float).reshape(10, 10)
    est = estimate_noise(frame, frame + 3.0)
    assert est.temporal_dn == 0.0 and est.spatial_dn == est.total_dn
    first = estimate_noise(frame)
    assert math.isnan(first.temporal_dn) and math.isnan(first.spatial_dn)


def test_detrend_removes_a_sky_gradient():
    rng = np.random.default_rng(3)
    ys, xs = np.mgrid[0:100, 0:120]
    frame = 1000 + 0.5 * xs + 0.2 * ys + rng.normal(0, 5.0, xs.shape)
    plain = estimate_noise(frame, region=(10, 10, 109, 89))
    flat = estimate_noise(frame, region=(10, 10, 109, 89), detrend=True)
    assert plain.total_dn > 10.0
    assert flat.total_dn == pytest.approx(5.0, rel=0.03) and flat.detrended


def test_meter_keeps_the_previous_region():
    previous, frame = _frames(2, shape=(60, 80))
    meter = NoiseMeter(region=(5, 5, 54, 44))
    assert math.isnan(meter.update(previous).temporal_dn)
    est = meter.update(frame)
    assert est == estimate_noise(frame, previous, region=(5, 5, 54, 44))


def test_bad_region_names_the_value():
    with pytest.raises(ValueError, match=r"\(0, 0, 10, 3\) leaves the 10x5 image"):
        estimate_noise(np.zeros((5, 10)), region=(0, 0, 10, 3))
