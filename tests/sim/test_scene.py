"""Scene renderer: reproducibility, drone energy, truth, phases, blackbody, clouds, confusers."""

from __future__ import annotations

import pickle

import numpy as np
import pytest
from scipy.special import ndtr

from snrmon.sim.drone import GaussianSpread, drone_patch
from snrmon.sim.example_scenes import lwir_example_scene, mwir_example_scene
from snrmon.sim.feed import FlightCameraFeed
from snrmon.sim.flight import FlightConfig, FlightPlan
from snrmon.sim.scene import SceneRenderer, TargetState
from snrmon.sim.sky import CloudConfig, Confuser

SMALL = {"width_px": 256, "height_px": 192}


def gaussian_average_pvf(sigma: float, fill_factor: float, n: int = 2001) -> float:
    """Average PVF of a Gaussian PSF (independent quadrature over one axis, squared)."""
    a = np.sqrt(fill_factor)
    d = (np.arange(n) + 0.5) / n - 0.5
    one_axis = (ndtr((a / 2 - d) / sigma) - ndtr((-a / 2 - d) / sigma)).mean()
    return float(one_axis**2)


def test_same_seed_same_frames_other_seed_other_frames():
    config = mwir_example_scene(**SMALL, clouds=CloudConfig(contrast_e=1e5, hole_radius_px=40))
    target = TargetState(120.3, 90.8, 5e4, 0.6)
    a = SceneRenderer(config, 7)
    b = pickle.loads(pickle.dumps(SceneRenderer(config, 7)))
    c = SceneRenderer(config, 8)
    for k in (0, 1, 5):
        fa = a.render(k, k / 60, target)
        assert np.array_equal(fa, b.render(k, k / 60, target))
        assert not np.array_equal(fa, c.render(k, k / 60, target))
    # Frames depend on (seed, index), not on call order.
    assert np.array_equal(a.render(1, 1 / 60, target), b.render(1, 1 / 60, target))


@pytest.mark.parametrize("size_px", [0.0, 0.6, 3.0, 9.0])
def test_drone_energy_is_the_configured_electrons_times_the_active_area_share(size_px):
    spread = GaussianSpread(0.8, 0.8)
    patch = drone_patch(spread, 50.37, 40.81, size_px, 1e5)
    total = float(patch.electrons.sum())
    # Over a uniform phase average the active area collects FF of the energy; at one phase the
    # share varies, but a window much bigger than the PSF holds all of it, so bounds are tight.
    assert 0.55 * 1e5 < total <= 1e5
    # Averaged over phases the captured share is the fill factor (energy not on active area is
    # lost in the gaps), for any source size.
    rng = np.random.default_rng(1)
    shares = [
        drone_patch(spread, 50 + rng.random(), 40 + rng.random(), size_px, 1.0).electrons.sum()
        for _ in range(400)
    ]
    assert np.mean(shares) == pytest.approx(0.8, rel=0.01)


def test_truth_snr_over_uniform_phases_is_the_average_pvf_snr():
    config = mwir_example_scene(**SMALL, fpn_enabled=False)
    r = SceneRenderer(config, 3)
    rng = np.random.default_rng(9)
    total_e = 4e4
    snrs = [
        r.truth_for(
            k, 0.0, TargetState(100 + rng.random(), 80 + rng.random(), total_e, 0.0)
        ).truth_snr
        for k in range(2000)
    ]
    expected = total_e * gaussian_average_pvf(0.8, 0.8) / config.temporal_noise_e
    assert np.mean(snrs) == pytest.approx(expected, rel=0.02)


def test_measured_peak_minus_background_matches_truth_without_noise_bias():
    config = mwir_example_scene(**SMALL, fpn_enabled=False)
    r = SceneRenderer(config, 4)
    target = TargetState(130.2, 70.6, 2e5, 0.5)
    r._prepare()
    diffs = []
    for k in range(200):
        frame, truth = r.render_with_truth(k, 0.0, target)
        diffs.append(
            frame[truth.peak_row, truth.peak_col]
            - (r.static_dn[truth.peak_row, truth.peak_col] - 0.5)
        )
    # Standard error of the mean here is ~0.6 DN.
    assert np.mean(diffs) == pytest.approx(truth.peak_signal_dn, abs=2.0)
    # The drone's own shot noise widens the peak pixel's noise beyond the sky's.
    assert np.std(diffs) > config.temporal_noise_dn


def test_flight_drift_makes_truth_snr_approach_the_average_pvf_prediction():
    config = lwir_example_scene(fpn_enabled=False)
    flight = FlightConfig(seed=2)
    feed = FlightCameraFeed(config, flight, fps=30.0, seed=1)
    plan = FlightPlan(flight)
    t0, _, planned = plan.stop_windows()[4]  # 393 m, unresolved in the LWIR
    first = int(np.ceil(t0 * 30))
    truths = [feed.truth(k) for k in range(first, first + 100)]
    assert not truths[0].resolved
    sigma_t = truths[0].size_px / 2
    pvf = gaussian_average_pvf(np.hypot(config.psf_sigma_px, sigma_t), config.fill_factor)
    expected = config.target.electrons_at(planned) * pvf / config.temporal_noise_e
    assert np.mean([t.truth_snr for t in truths]) == pytest.approx(expected, rel=0.10)


def test_resolved_drone_is_an_extended_box_with_a_flat_top():
    spread = GaussianSpread(0.5, 1.0)
    patch = drone_patch(spread, 20.0, 20.0, 9.0, 81.0)
    row = patch.electrons[patch.electrons.shape[0] // 2]
    inner = row[len(row) // 2 - 2 : len(row) // 2 + 3]
    assert np.allclose(inner, 1.0, atol=1e-3)  # a box of 9x9 px carrying 1 e-/px^2
    assert spread.is_resolved(9.0) and not spread.is_resolved(0.9)


def test_blackbody_mode_is_uniform_through_the_same_fixed_pattern():
    config = mwir_example_scene(**SMALL, blackbody_e=3e5, sky_gradient_e_per_px=(0, 60))
    r = SceneRenderer(config, 5)
    frames = np.stack([r.render(k, 0.0, TargetState(100, 100, 1e6, 0.5)) for k in range(32)])
    mean = frames.astype(float).mean(axis=0)
    expected_dn = config.dn_offset + 3e5 / config.gain_e_per_dn
    assert mean.mean() == pytest.approx(expected_dn, abs=1.0)
    sky = SceneRenderer(mwir_example_scene(**SMALL), 5)
    sky._prepare()
    # Same seed -> same offsets; the drone and the sky gradient are absent.
    assert np.corrcoef((mean - mean.mean()).ravel(), sky.fpn.offset_dn.ravel())[0, 1] > 0.8
    assert r.truth_for(0, 0.0, TargetState(100, 100, 1e6, 0.5)) is None
    assert config.temporal_noise_dn < mwir_example_scene().temporal_noise_dn


def test_clouds_leave_a_clear_hole_around_the_line_of_sight_and_drift():
    config = mwir_example_scene(
        fpn_enabled=False,
        clouds=CloudConfig(contrast_e=2e5, hole_radius_px=100, cover=0.8),
    )
    r = SceneRenderer(config, 6)
    frame = r.render(0, 10.0, None).astype(float)
    r._prepare()
    cx, cy = r.clouds.hole_centre_px(10.0)
    hole = frame[int(cy) - 30 : int(cy) + 30, int(cx) - 30 : int(cx) + 30]
    sky_level = r.static_dn[int(cy), int(cx)] - 0.5
    assert abs(hole.mean() - sky_level) < 3.0
    assert frame.max() - sky_level > 0.5 * 2e5 / config.gain_e_per_dn  # clouds elsewhere
    assert r.clouds.offset_px(0.0) != r.clouds.offset_px(20.0)


def test_confuser_crosses_as_a_bright_moving_blob():
    bird = Confuser(
        t_start_s=1.0,
        duration_s=2.0,
        x0_px=20,
        y0_px=50,
        vx_px_per_s=40,
        vy_px_per_s=0,
        total_e=5e5,
    )
    config = mwir_example_scene(**SMALL, fpn_enabled=False, confusers=(bird,))
    r = SceneRenderer(config, 7)
    before = r.render(0, 0.5, None)
    during = r.render(1, 2.0, None)
    later = r.render(2, 2.5, None)
    assert during[50, 60] - before[50, 60] > 100
    assert later[50, 80] - before[50, 80] > 100
    assert abs(int(later[50, 60]) - int(before[50, 60])) < 60


def test_twin_scene_is_the_twin_cameras_chain():
    """The twin's scene takes every number from its own photon chain: the sky's charge, the
    floor noise, the drone's contrast per range, a calibration blackbody's charge."""
    from snrmon.model import presets
    from snrmon.sim.radiometry import TwinCamera
    from snrmon.sim.twin import Scenario, blackbody_scene, twin_scene_config

    sensor = presets.load_sensor("mwir")
    cam = TwinCamera.from_sensor(sensor)
    config = twin_scene_config(sensor, presets.load_target("uav1"), Scenario(sky_temp_k=250.0))
    assert config.sky_e == cam.pixel_electrons(250.0)
    assert config.floor_noise_e == sensor.read_noise_e  # a photon counter: read noise only
    assert config.poisson_shot_noise
    assert config.target.size_m == 0.157
    warm = blackbody_scene(config, sensor, 300.0)
    assert warm.blackbody_e == cam.pixel_electrons(300.0) > config.sky_e


def test_poisson_charge_in_the_fresh_window():
    """With ``poisson_shot_noise`` the charge around the drone is Poisson: whole electrons,
    variance equal to the mean (a Gaussian of that variance would give neither)."""
    config = mwir_example_scene(
        **SMALL,
        sky_e=30.0,
        sky_gradient_e_per_px=(0.0, 0.0),
        floor_noise_e=0.0,
        gain_e_per_dn=1.0,
        dn_offset=100.0,
        fpn_enabled=False,
        target_shot_noise=True,
        poisson_shot_noise=True,
    )
    r = SceneRenderer(config, 3)
    target = TargetState(x_px=128.0, y_px=96.0, total_e=0.0, size_px=0.3)
    frames = np.array([r.render_with_truth(k, 0.0, target)[0] for k in range(40)], float)
    window = frames[:, 80:112, 112:144] - 100.0  # inside the fresh window, no drone light
    assert window.mean() == pytest.approx(30.0, rel=0.02)
    assert window.var() == pytest.approx(30.0, rel=0.05)
    assert np.all(window >= 0)


def test_truth_snr_of_the_twin_approaches_its_average_pvf_snr():
    from snrmon.model import presets
    from snrmon.sim.twin import Scenario, twin_scene_config

    sensor = presets.load_sensor("mwir")
    target = presets.load_target("uav1")
    config = twin_scene_config(
        sensor, target, Scenario(), spread=None, psf_sigma_px=0.8, fpn_enabled=False
    )
    feed = FlightCameraFeed(config, FlightConfig(seed=3), fps=60.0, seed=2)
    t0, _, planned = FlightPlan(FlightConfig(seed=3)).stop_windows()[-1]  # 508 m
    first = int(np.ceil(t0 * 60))
    truths = [feed.truth(k) for k in range(first, first + 300)]
    sigma = np.hypot(0.8, truths[0].size_px / 2)
    expected = (
        config.target.electrons_at(planned)
        * gaussian_average_pvf(sigma, config.fill_factor)
        / config.temporal_noise_e
    )
    assert np.mean([t.truth_snr for t in truths]) == pytest.approx(expected, rel=0.10)


def _fixed_window_fractions(dx, dy, target_sigma_px):
    """A fixed 7x7 window of fractions, as model.pvf.pixel_energy_fractions returns."""
    from snrmon.sim.drone import gaussian_fractions_1d

    s = np.hypot(0.8, target_sigma_px)
    return np.outer(gaussian_fractions_1d(3, dy, s, 0.8), gaussian_fractions_1d(3, dx, s, 0.8))


def test_tabulated_spread_reproduces_its_function_at_the_phase_grid():
    from snrmon.sim.drone import TabulatedSpread

    fn = _fixed_window_fractions
    tab = pickle.loads(pickle.dumps(TabulatedSpread(fn, GaussianSpread(0.8, 0.8), phases=8)))
    got = drone_patch(tab, 10.0 + 1 / 16, 5.0 - 3 / 16, 0.5, 1000.0).electrons
    assert np.allclose(got, 1000.0 * fn(1 / 16, -3 / 16, 0.25), rtol=1e-5)
    assert tab.is_resolved(3.0) and tab.fractions(0.1, 0.2, 3.0).shape[0] > 7


def test_blackbody_captures_share_the_cameras_fixed_pattern():
    """A calibration needs the same gain/offset maps at every blackbody temperature: the pattern
    belongs to the camera (defined on the sky), not to the level being rendered."""
    import dataclasses

    from snrmon.sim.example_scenes import mwir_example_scene
    from snrmon.sim.scene import SceneRenderer

    base = mwir_example_scene(width_px=64, height_px=48)
    cold = SceneRenderer(dataclasses.replace(base, blackbody_e=base.sky_e * 0.5), seed=4)
    hot = SceneRenderer(dataclasses.replace(base, blackbody_e=base.sky_e * 2.0), seed=4)
    sky = SceneRenderer(base, seed=4)
    for r in (cold, hot, sky):
        r._prepare()  # built lazily on the first frame
    for r in (cold, hot):
        assert np.array_equal(r.fpn.gain, sky.fpn.gain)
        assert np.array_equal(r.fpn.offset_dn, sky.fpn.offset_dn)
