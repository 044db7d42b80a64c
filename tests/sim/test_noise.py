"""Noise of the simulated cameras: temporal std, fixed pattern, bank, fresh window, quantisation."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.sim.example_scenes import lwir_example_scene, mwir_example_scene
from snrmon.sim.noise import NoiseBank, floor_noise_for, max_dn, quantize_dn, temporal_noise_e
from snrmon.sim.scene import SceneRenderer, TargetState

SMALL = {"width_px": 320, "height_px": 240}


def test_floor_noise_reproduces_the_configured_temporal_noise():
    floor = floor_noise_for(6.6, 140.0, 6.57e5)
    assert temporal_noise_e(floor, 6.57e5) / 140.0 == pytest.approx(6.6, rel=1e-12)
    with pytest.raises(ValueError, match="below the shot noise"):
        floor_noise_for(1.0, 140.0, 6.57e5)


@pytest.mark.parametrize("make, sigma", [(mwir_example_scene, 6.6), (lwir_example_scene, 5.8)])
def test_temporal_noise_on_clear_sky_matches_the_paper_dn(make, sigma):
    config = make(**SMALL, fpn_enabled=True)
    r = SceneRenderer(config, seed=11)
    frames = np.stack([r.render(k, k / 60, None) for k in range(40)]).astype(np.float64)
    # Temporal noise from frame differences: a difference carries sqrt(2) x the single-frame std.
    diff = np.diff(frames, axis=0)[:, 20:-20, 20:-20]
    measured = diff.std() / np.sqrt(2.0)
    # Quantisation adds 1/12 DN^2 of variance to each frame.
    assert measured == pytest.approx(np.hypot(sigma, np.sqrt(1 / 12)), rel=0.02)


def test_fixed_pattern_is_the_configured_multiple_of_temporal_noise():
    config = mwir_example_scene(**SMALL, fpn_multiple=2.5, sky_gradient_e_per_px=(0.0, 0.0))
    r = SceneRenderer(config, seed=5)
    frames = np.stack([r.render(k, 0.0, None) for k in range(64)]).astype(np.float64)
    spatial = frames.mean(axis=0).std()  # temporal part averaged down by sqrt(64)
    temporal_left = config.temporal_noise_dn / np.sqrt(64)
    fpn = np.sqrt(spatial**2 - temporal_left**2)
    assert fpn / config.temporal_noise_dn == pytest.approx(2.5, rel=0.05)
    # Seeded: the same seed gives the same pattern, another seed a different one.
    again = SceneRenderer(config, seed=5)
    again._prepare()
    r2 = SceneRenderer(config, seed=6)
    r2._prepare()
    assert np.array_equal(again.fpn.offset_dn, r.fpn.offset_dn)
    assert not np.array_equal(r2.fpn.offset_dn, r.fpn.offset_dn)


def test_noise_bank_windows_differ_between_frames_and_keep_sigma():
    bank = NoiseBank((50, 60), 3.0, planes=2, margin_px=16, seed=1)
    rng = np.random.default_rng(0)
    views = [bank.draw(rng) for _ in range(20)]
    stacked = np.stack([v * s for v, s in views])
    assert stacked.std() == pytest.approx(3.0, rel=0.03)
    # Consecutive draws are different fields.
    assert all(not np.array_equal(stacked[i], stacked[i + 1]) for i in range(19))


@pytest.mark.slow
def test_fresh_noise_around_the_drone_never_repeats_the_bank():
    config = mwir_example_scene(**SMALL, fpn_enabled=False, fresh_half_px=10)
    r = SceneRenderer(config, seed=2)
    target = TargetState(160.0, 120.0, total_e=0.0, size_px=0.5)
    r._prepare()
    bank = r.bank.planes
    static = r.static_dn - 0.5
    for k in range(5):
        frame, truth = r.render_with_truth(k, 0.0, target)
        r0, r1, c0, c1 = truth.fresh_window
        assert (r1 - r0, c1 - c0) == (21, 21)
        noise = frame[r0:r1, c0:c1].astype(np.float64) - static[r0:r1, c0:c1]
        # Correlate the window's noise with every bank position it could have come from.
        best = 0.0
        for p in range(bank.shape[0]):
            for oy in range(0, r.bank.margin_px + 1, 4):
                for ox in range(0, r.bank.margin_px + 1, 4):
                    b = bank[p, oy + r0 : oy + r1, ox + c0 : ox + c1]
                    best = max(best, abs(np.corrcoef(b.ravel(), noise.ravel())[0, 1]))
        assert best < 0.35
        # Outside the window the noise IS a bank window (proves the test would catch it).
        outside = frame[0:21, 0:21].astype(np.float64) - static[0:21, 0:21]
        corr = max(
            abs(np.corrcoef(bank[p, oy : oy + 21, ox : ox + 21].ravel(), outside.ravel())[0, 1])
            for p in range(bank.shape[0])
            for oy in range(r.bank.margin_px + 1)
            for ox in range(r.bank.margin_px + 1)
        )
        assert corr > 0.95


def test_consecutive_frames_in_the_drone_window_are_independent():
    config = mwir_example_scene(**SMALL, fpn_enabled=False)
    r = SceneRenderer(config, seed=4)
    target = TargetState(100.2, 90.7, total_e=0.0, size_px=0.3)
    a, ta = r.render_with_truth(0, 0.0, target)
    b, _ = r.render_with_truth(1, 1 / 60, target)
    r0, r1, c0, c1 = ta.fresh_window
    d = a[r0:r1, c0:c1].astype(float) - b[r0:r1, c0:c1].astype(float)
    assert d.std() / np.sqrt(2) == pytest.approx(config.temporal_noise_dn, rel=0.1)


def test_quantisation_rounds_clips_and_saturates_at_14_bits():
    buf = np.array([[-3.0, 0.4 + 0.5, 1.6 + 0.5, 16383.2 + 0.5, 70000.0]], np.float32)
    out = quantize_dn(buf, 14)
    assert out.dtype == np.uint16
    assert out.tolist() == [[0, 0, 2, 16383, 16383]]
    assert max_dn(14) == 16383
    with pytest.raises(ValueError, match="bit depth"):
        max_dn(17)


def test_a_bright_drone_saturates_at_full_scale_and_truth_says_so():
    config = mwir_example_scene(**SMALL, fpn_enabled=False)
    r = SceneRenderer(config, seed=1)
    frame, truth = r.render_with_truth(0, 0.0, TargetState(150.0, 100.0, 5e9, 0.2))
    assert frame.max() == 16383
    assert frame[truth.peak_row, truth.peak_col] == 16383
    assert truth.saturated
    assert frame.max() <= (1 << config.bit_depth) - 1
