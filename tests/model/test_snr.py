"""Eqs. 2-3, the paper's resolved/unresolved rule and its switched curves, the continuous
square-target curves, the band, and the hooks the scene simulator uses."""

import dataclasses
import math

import numpy as np
import pytest

from snrmon.model.detector import background_electrons
from snrmon.model.noise import temporal_noise_e
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.psf import AiryGaussianPsf
from snrmon.model.pvf import average_pvf, average_pvf_vs_target_sigma, pixel_energy_fractions
from snrmon.model.radiometry import band_nodes, spectral_photon_radiance
from snrmon.model.snr import detection_range_m, predict, target_contrast_electrons
from snrmon.model.target import Target

MW, LW = load_sensor("mwir"), load_sensor("lwir")
UAV1, UAV2 = load_target("uav1"), load_target("uav2")
PAPER_RANGES = [37, 126, 199, 336, 393, 451, 508]


def test_transition_range_uav1_small_mwir():
    p = predict(MW, UAV1, PAPER_RANGES, geometry="paper", expected=False, band=False)
    assert 314 <= p.transition_range_small_m <= 350
    assert list(p.resolved_small) == [True, True, True, False, False, False, False]
    assert list(p.resolved_large) == [True] * 6 + [False]
    # the paper's unresolved MWIR ranges (section 4) are unresolved for the small dimension
    assert not p.resolved_small[3:].any()


def test_eq2_point_signal_by_hand():
    # an independent worked example: 5 K contrast, tau 0.8, 15.7 cm target, 290 K background
    s = MW.__class__(**{**MW.__dict__, "t_int_s": 0.005})
    t = Target("bb", 0.157, 0.157, {"mwir": 295.0 - 273.15})
    kw = {"atmosphere": 0.8, "background_temp_k": 290.0, "air_temp_k": 290.0}
    e199 = target_contrast_electrons(s, t, 199.0, **kw)
    e508 = target_contrast_electrons(s, t, 508.0, **kw)
    assert e199 == pytest.approx(3.37e5, rel=0.01)
    assert e508 == pytest.approx(5.17e4, rel=0.01)
    wl, w = band_nodes((3.45, 5.25), 48)
    dlq = spectral_photon_radiance(wl, 295.0) - spectral_photon_radiance(wl, 290.0)
    by_hand = s.aperture_area_m2 * 0.005 * 0.8 * np.sum(w * 0.8 * 0.9 * 0.6 * dlq)
    assert e199 == pytest.approx(by_hand * 0.157**2 / 199.0**2, rel=1e-12)


def test_four_paper_curves_unresolved_use_pvf_and_eq3():
    p = predict(MW, UAV1, PAPER_RANGES, spatial_noise="2x", geometry="paper", expected=False)
    i = 6  # 508 m: both dimensions unresolved
    pt = target_contrast_electrons(MW, UAV1, 508.0)
    pvf0 = average_pvf(MW.diffraction_psf(), 0.8)
    assert p.signal_e["small"][i] == pytest.approx(pt * pvf0, rel=1e-9)
    assert p.pvf["small"][i] == pytest.approx(pvf0)
    d_px = 0.157 / (508.0 * MW.ifov_rad)
    assert p.pvf["small_corrected"][i] == pytest.approx(
        average_pvf(MW.corrected_psf(), 0.8, 0.5 * d_px), abs=1e-6
    )
    assert p.noise.spatial == pytest.approx(2 * p.noise.temporal)
    assert p.snr_small[i] == pytest.approx(p.signal_e["small"][i] / (5**0.5 * p.noise.temporal))
    assert np.isnan(p.pvf["small"][0]) and p.snr_small[0] == p.snr_small_corrected[0]
    assert (p.snr_small_corrected[3:] < p.snr_small[3:]).all()
    assert (p.snr_large >= p.snr_small).all()


def test_mwir_corrected_pvf_is_0082_for_a_point_and_drops_with_size():
    psf = MW.corrected_psf()
    # the diffraction limit blurred by the Gaussian that gives the paper's 0.082 (section 8)
    assert isinstance(psf, AiryGaussianPsf) and psf.airy == MW.diffraction_psf()
    assert psf.sigma_px == pytest.approx(0.946, abs=2e-3)
    p = predict(MW, UAV1, [400.0, 4000.0, 40000.0], geometry="paper", expected=False)
    assert p.pvf["small_corrected"][2] == pytest.approx(0.082, abs=2e-4)
    assert p.pvf["small_corrected"][0] < p.pvf["small_corrected"][1] < 0.082


def test_background_correction_and_atmosphere_move_the_signal_the_right_way():
    cold = predict(LW, UAV1, [300.0], background_temp_k=280.0).snr_small[0]
    warm = predict(LW, UAV1, [300.0], background_temp_k=306.65).snr_small[0]  # 33.5 C sky
    assert cold > 3 * warm > 0
    clear = predict(MW, UAV1, [400.0], atmosphere="none").snr_small[0]
    hazy = predict(MW, UAV1, [400.0], atmosphere="default").snr_small[0]
    tau = predict(MW, UAV1, [400.0]).transmission_contrast[0]
    # the signal's own weighting (this target's contrast) against dLq/dT at the air: within 1 %
    assert hazy / clear == pytest.approx(tau, rel=0.01)


def test_uncertainty_band_surrounds_corrected_curves_and_path_term_is_amplified():
    p = predict(MW, UAV1, PAPER_RANGES)
    c = p.snr_small_corrected
    assert (p.lower["small_corrected"] < c).all() and (c < p.upper["small_corrected"]).all()
    u = p.relative_uncertainty["small_corrected"]
    assert u[-1] > u[0]  # MTF and size-blur terms only once unresolved
    warm = predict(LW, UAV1, [300.0], background_temp_k=306.65).relative_uncertainty
    assert warm["small_corrected"][0] > 0.5  # 5 % of a large background vs a small contrast


def test_detection_range_is_where_the_curve_crosses_the_threshold():
    r = detection_range_m(MW, UAV1, 5.0)
    above = predict(MW, UAV1, [r * 0.999]).snr_small_corrected[0]
    below = predict(MW, UAV1, [r * 1.001]).snr_small_corrected[0]
    assert above >= 5.0 > below
    assert detection_range_m(MW, UAV1, 1e9) == 0.0


def test_simulator_hooks_reproduce_the_model_snr():
    # render the unresolved drone with the model's own fractions at random phases: the mean
    # peak-pixel signal over phases / temporal noise = the model's corrected SNR (Eqs. 2-3)
    rng = np.random.default_rng(7)
    r = 451.0
    p = predict(MW, UAV1, [r], background_temp_k=285.0, geometry="paper", expected=False)
    e = target_contrast_electrons(MW, UAV1, r, background_temp_k=285.0)
    st = 0.5 * 0.157 / (r * MW.ifov_rad)
    psf = MW.corrected_psf()
    mids = [
        pixel_energy_fractions(
            psf, *rng.uniform(-0.5, 0.5, 2), fill_factor=0.8, target_sigma_px=st
        )[3, 3]
        for _ in range(4000)
    ]
    sim_snr = e * np.mean(mids) / temporal_noise_e(MW, 285.0)
    assert sim_snr == pytest.approx(p.snr_small_corrected[0], rel=0.01)
    assert background_electrons(MW, 285.0) > temporal_noise_e(MW, 285.0) ** 2 - 100.0**2 - 1


def test_to_records_shape_and_bad_ranges():
    recs = predict(LW, UAV2, [126.0, 393.0], geometry="paper").to_records()
    assert len(recs) == 2
    assert set(recs[0]) >= {
        "range_m",
        "resolved_small",
        "resolved_large",
        "snr_small",
        "snr_large",
        "snr_small_corrected",
        "snr_large_corrected",
        "signal_e",
        "noise_e",
        "transmission",
        "pvf",
        "expected_eq4_rim",
        "expected_eq4_extent",
        "snr_paper",
        "transmission_contrast",
    }
    assert set(recs[0]["noise_e"]) == {"background", "lens", "dark", "read", "temporal", "spatial"}
    assert recs[0]["pvf"]["small"] is None and recs[1]["pvf"]["small"] > 0.3
    with pytest.raises(ValueError, match="range"):
        predict(MW, UAV1, [100.0, -5.0])


def test_measured_noise_replaces_the_models_in_eq3():
    """The operator's "measured noise": Eq. 3's denominator is the camera's sigma_tvh and
    sigma_vh (DN) times the sensor's gain; every curve scales by the ratio of the noises."""
    from snrmon.model.noise import MeasuredNoise, noise_breakdown

    sensor, target = load_sensor("mwir"), load_target("uav1")
    ranges = [60.0, 150.0, 400.0]
    own = predict(sensor, target, ranges, band=False, expected=False)
    measured = MeasuredNoise(temporal_dn=3.0, spatial_dn=4.0)  # 5 DN in quadrature
    p = predict(sensor, target, ranges, measured_noise=measured, band=False, expected=False)
    g = sensor.gain_e_per_dn
    assert (p.noise.temporal, p.noise.spatial) == (3.0 * g, 4.0 * g)
    assert p.noise.total == pytest.approx(5.0 * g)
    assert p.noise.background == own.noise.background  # Eq. 1's terms stay, for comparison
    for curve in ("small", "large", "small_corrected", "large_corrected"):
        np.testing.assert_allclose(
            p.snr(curve), own.snr(curve) * own.noise.total / (5.0 * g), rtol=1e-12
        )
    # the Monte-Carlo band draws the sky, but the measured noise is the same in every draw:
    # twice the noise halves the whole band
    banded = predict(sensor, target, ranges, measured_noise=measured, expected=False)
    double = predict(sensor, target, ranges, measured_noise=MeasuredNoise(6.0, 8.0), expected=False)
    for edge in ("lower", "upper"):
        np.testing.assert_allclose(
            getattr(double, edge)["small_corrected"],
            getattr(banded, edge)["small_corrected"] / 2,
            rtol=1e-12,
        )
    with pytest.raises(ValueError, match="spatial noise or a measured noise, not both"):
        noise_breakdown(sensor, 280.0, "medium", measured)
    for bad in (-1.0, math.nan):
        with pytest.raises(ValueError, match="temporal_dn must be >= 0 DN"):
            MeasuredNoise(bad, 1.0)
    with pytest.raises(ValueError, match="0 DN"):
        MeasuredNoise(0.0, 0.0)


@pytest.mark.parametrize("real_psf", ["airy+gaussian", "airy"])
def test_papers_corrected_lwir_curve_applies_the_finite_size_correction(real_psf):
    """Section 8: the LWIR's corrected curves carry the finite-size correction (sigma_t = D/2
    convolved with the PSF) even where its real PSF IS the diffraction limit: the corrected
    value is the point source times that PVF, not the uncorrected one."""
    sensor = dataclasses.replace(LW, real_psf=real_psf)
    p = predict(sensor, UAV1, [199.0], atmosphere="none", geometry="paper", band=False)
    d = UAV1.small_m / (199.0 * LW.ifov_rad)  # 0.78 px: unresolved
    point = p.point_contrast_e["small"][0] / p.noise.total
    real, airy = sensor.corrected_psf(), sensor.diffraction_psf()
    assert p.paper["small"][0] == pytest.approx(point * average_pvf(airy, 0.9), rel=1e-9)
    corrected = point * float(average_pvf_vs_target_sigma(real, 0.9, d / 2))
    assert p.paper["small_corrected"][0] == pytest.approx(corrected, rel=1e-6)
    assert p.paper["small_corrected"][0] < 0.7 * p.paper["small"][0]


@pytest.mark.parametrize("geometry", ["square", "paper"])
@pytest.mark.parametrize("target", [UAV1, UAV2])
@pytest.mark.parametrize("sensor", [MW, LW])
def test_no_corrected_curve_exceeds_its_diffraction_limit(sensor, target, geometry):
    """The real PSF is the diffraction limit blurred (aberrations, jitter): at no range does a
    corrected curve read more than its diffraction-limited one (a pure-Gaussian "real" PSF,
    narrower in its wings than the Airy, had read 511 against 484 at MWIR 37 m)."""
    real = sensor.corrected_psf()
    assert isinstance(real, AiryGaussianPsf) and real.airy == sensor.diffraction_psf()
    r = np.geomspace(20.0, 1500.0, 400)
    p = predict(sensor, target, r, geometry=geometry, expected=False, band=False)
    for size in ("small", "large"):
        for curves in ({c: p.snr(c) for c in (size, f"{size}_corrected")}, p.paper):
            assert np.all(curves[f"{size}_corrected"] <= curves[size] * (1 + 1e-9)), size
        assert np.any(p.snr(f"{size}_corrected") < 0.99 * p.snr(size))  # it does correct
