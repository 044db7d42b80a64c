"""The continuous model: the square target's phase-averaged ensquared energy, its
limits, no jump at the transition, separate sky and air, the contrast-weighted transmission,
and the audit's numbers each pinned."""

import json

import numpy as np
import pytest

from snrmon.cli import main
from snrmon.model.atmosphere import default_atmosphere, resolve_atmosphere
from snrmon.model.atmosphere_table import Weather
from snrmon.model.footprint import average_pvf_square, phase_grid, pixel_patterns
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.pvf import average_pvf, average_pvf_vs_target_sigma
from snrmon.model.snr import predict

MW, LW = load_sensor("mwir"), load_sensor("lwir")
UAV1 = load_target("uav1")


@pytest.mark.parametrize("psf", [MW.diffraction_psf(), MW.corrected_psf(), LW.diffraction_psf()])
def test_square_pvf_is_the_point_pvf_at_zero_and_the_phase_average_of_the_patterns(psf):
    ff = 0.8
    assert average_pvf_square(psf, ff, 0.0) == pytest.approx(average_pvf(psf, ff), abs=1e-6)
    ph = np.linspace(-0.5, 0.5, 24, endpoint=False) + 1 / 48
    for d in (0.4, 1.3):
        mid = pixel_patterns(psf, ff, ph, ph, target_square_px=d)[:, :, 3, 3].mean()
        assert mid == pytest.approx(average_pvf_square(psf, ff, d), rel=2e-3)
    # the symmetric half-cell grid averages to the same value
    half = phase_grid(6)
    assert pixel_patterns(psf, ff, half, half, target_square_px=1.3)[:, :, 3, 3].mean() == (
        pytest.approx(average_pvf_square(psf, ff, 1.3), rel=2e-3)
    )


def test_square_pvf_tends_to_the_pixel_filling_limit():
    ff = MW.fill_factor
    for psf in (MW.diffraction_psf(), MW.corrected_psf()):
        share = [average_pvf_square(psf, ff, d) * d * d / ff for d in (16.0, 64.0, 1000.0)]
        assert share[0] < share[1] < share[2] <= 1.0 + 1e-4
        assert share[2] == pytest.approx(1.0, abs=1e-3)
    # at 37 m (an 8.5-px square) the Airy's wings (energy outside r ~ 2q/(pi^2 r)) keep 5.8 %
    # of the light of its centre pixel outside the square; the real PSF, that Airy blurred,
    # keeps a little more out: never less (a pure Gaussian, whose wings are narrower than the
    # Airy's, had read 1.00 here: a "real" PSF better than the diffraction limit)
    d37 = UAV1.small_m / (37.0 * MW.ifov_rad)
    real = average_pvf_square(MW.corrected_psf(), ff, d37) * d37**2 / ff
    airy = average_pvf_square(MW.diffraction_psf(), ff, d37) * d37**2 / ff
    assert airy == pytest.approx(0.942, abs=0.005)
    assert 0.99 * airy < real < airy


def test_resolved_limit_is_the_papers_resolved_formula_at_37_m():
    p = predict(MW, UAV1, [37.0], expected=False, band=False)
    paper = predict(MW, UAV1, [37.0], geometry="paper", expected=False, band=False)
    assert paper.resolved_small[0]
    # the corrected (real PSF) curve at 37 m is the pixel-filling radiance less the PSF's wings
    # outside the 8.5-px square (6 %), and below the diffraction limit
    assert p.snr_small_corrected[0] == pytest.approx(0.937 * paper.snr_small_corrected[0], rel=0.01)
    assert p.snr_small_corrected[0] < p.snr_small[0]
    # and as D -> infinity the square's signal IS the resolved formula, by construction
    ext = paper.signal_e["small_corrected"][0]
    d = 1e6
    limit = (
        p.point_contrast_e["small"][0]
        * MW.fill_factor
        / d**2
        * (d / (UAV1.small_m / (37.0 * MW.ifov_rad))) ** 2
    )
    assert limit == pytest.approx(ext, rel=1e-9)


def _jump(snr: np.ndarray) -> float:
    """The largest step of log SNR between neighbouring ranges over the larger of the steps
    two ranges before and after it: ~1 on a smooth curve, >> 1 at a jump."""
    d = np.abs(np.diff(np.log(snr)))
    around = np.maximum(d[:-4], d[4:])
    return float(np.max(d[2:-2] / np.maximum(around, 1e-6)))


def test_model_snr_json_10_to_1000_m_has_no_jump(capsys):
    ranges = ",".join(str(r) for r in range(10, 1001))
    assert (
        main(["model", "snr", "--sensor", "mwir", "--target", "uav1", "--ranges", ranges, "--json"])
        == 0
    )
    recs = json.loads(capsys.readouterr().out)
    assert len(recs) == 991 and recs[0]["range_m"] == 10.0
    for key in (
        "snr_small",
        "snr_large",
        "snr_small_corrected",
        "snr_large_corrected",
        "expected_eq4_rim",
        "expected_eq4_extent",
    ):
        assert _jump(np.array([r[key] for r in recs])) < 1.5, key
    # the same statistic catches the paper's switch (so the test can fail): 393 -> 130 at 314 m
    paper = np.array([r["snr_paper"]["small"] for r in recs])
    assert _jump(paper) > 50
    i = 314 - 10
    assert paper[i - 1] / paper[i + 1] > 2.5


def test_the_switch_the_audit_found_and_the_continuous_value():
    below, above = predict(
        MW, UAV1, [313.9, 314.1], geometry="paper", expected=False, band=False
    ).snr_small
    jump = 0.8 / average_pvf(MW.diffraction_psf(), 0.8)  # FF / PVF: the paper's step
    assert below / above == pytest.approx(jump, rel=0.02)
    cont = predict(MW, UAV1, [313.9, 314.1], expected=False, band=False).snr_small
    assert cont[0] / cont[1] == pytest.approx(1.0, abs=0.002)
    # the square of side 1 px with the Airy: 0.844 of the point source, no branch jumps
    assert cont[0] / above == pytest.approx(0.844, abs=0.005)


def test_finite_size_numbers_of_the_audit():
    """sigma_t = D/2 with the 0.082 PSF: 0.081/0.078/0.069 (the paper: 0.080/0.076/0.062);
    the square of side D: 0.0817/0.0808/0.0772. In the LWIR at 199 m (D = 0.78 px) the
    Gaussian rule drops the SNR 35 %, the square 16 %."""
    real = MW.corrected_psf()
    gauss = [float(average_pvf_vs_target_sigma(real, 0.8, 0.5 * d)) for d in (0.25, 0.5, 1.0)]
    square = [average_pvf_square(real, 0.8, d) for d in (0.25, 0.5, 1.0)]
    assert gauss == pytest.approx([0.0811, 0.0784, 0.0693], abs=2e-4)
    assert square == pytest.approx([0.0817, 0.0808, 0.0772], abs=2e-4)
    airy = LW.diffraction_psf()
    d = UAV1.small_m / (199.0 * LW.ifov_rad)
    point = average_pvf(airy, 0.9)
    gauss = float(average_pvf_vs_target_sigma(airy, 0.9, d / 2))
    assert gauss / point == pytest.approx(0.65, abs=0.01)
    assert average_pvf_square(airy, 0.9, d) / point == pytest.approx(0.84, abs=0.01)


def test_air_and_sky_are_separate_and_the_air_adds_contrast():
    kw = {"expected": False, "band": False, "background_temp_k": 280.0}
    same = predict(MW, UAV1, [199.0, 508.0], air_temp_k=280.0, **kw)
    warm_air = predict(MW, UAV1, [199.0, 508.0], air_temp_k=288.15, **kw)
    gain = warm_air.snr_small / same.snr_small
    assert 1.07 < gain[0] < gain[1] < 1.16  # more path in front of the drone farther out
    assert warm_air.air_temp_k == 288.15 and warm_air.background_temp_k == 280.0
    assert warm_air.noise.temporal == same.noise.temporal  # the noise is the sky's
    # no sky given: the infinite path at the air temperature, as before
    own = predict(MW, UAV1, [199.0], expected=False, band=False)
    assert own.background_temp_k == own.air_temp_k == pytest.approx(288.15, abs=1e-9)
    assert own.sky_assumed and not warm_air.sky_assumed


def test_contrast_weighted_transmission_of_the_mwir_default():
    # LOWTRAN7 US Standard 1976 sea level (CO2 420 ppmv), rural aerosol at 23 km: the flat band
    # average and the one weighted by dLq/dT at the air, 7 % lower at 199 m and 13 % at 508 m
    atm = default_atmosphere((3.45, 5.25))
    assert atm.transmission([199.0, 508.0]) == pytest.approx([0.740, 0.654], abs=0.002)
    assert atm.contrast_transmission([199.0, 508.0]) == pytest.approx([0.686, 0.567], abs=0.002)
    p = predict(MW, UAV1, [199.0], expected=False, band=False)
    assert p.transmission_contrast[0] == pytest.approx(atm.contrast_transmission(199.0), abs=1e-3)
    assert p.transmission[0] == pytest.approx(atm.transmission(199.0), abs=1e-9)
    lw = default_atmosphere((8.0, 12.0))  # nearly grey: weighted and flat within 0.2 %
    assert lw.contrast_transmission(199.0) == pytest.approx(lw.transmission(199.0), rel=0.002)


def test_the_bolometers_contrast_transmission_is_weighted_in_photons_as_its_signal():
    """The LWIR preset is a bolometer whose signal the model integrates in photons (absorbed
    photons x absorptance): its contrast-weighted transmission is weighted in photons too, the
    signal's own band transmission. Weighted in power it read 1.0 % high at 1.5 km in humid air
    and 0.6 % low in the default air."""
    assert LW.detector == "bolometer"
    humid = Weather(air_temp_c=30.0, rh_percent=90.0)
    for air, power_over_photon in ((humid, 1.010), (None, 0.994)):
        p = predict(LW, UAV1, [1500.0], expected=False, band=False, atmosphere=air)
        atm = resolve_atmosphere(air, tuple(LW.band_um))
        photon = atm.contrast_transmission(1500.0, tuple(LW.band_um))
        power = atm.contrast_transmission(1500.0, tuple(LW.band_um), photon=False)
        assert p.transmission_contrast[0] == pytest.approx(photon, rel=2e-3)
        assert power / photon == pytest.approx(power_over_photon, abs=0.002)
    assert "contrast-weighted" in atm.source


def test_band_is_one_sided_where_the_paper_says_so():
    # a measured sky: an assumed one widens the band on both sides (test_sky_assumed_...)
    p = predict(MW, UAV1, [250.0, 451.0, 2000.0], background_temp_k=288.15)
    for name in ("small_corrected", "large_corrected", "expected_eq4_rim", "expected_eq4_extent"):
        lo, hi, mid = p.lower[name], p.upper[name], p.snr(name)
        assert (lo < mid).all() and (mid < hi).all()
    c = p.snr_small_corrected
    down = (c - p.lower["small_corrected"]) / c
    up = (p.upper["small_corrected"] - c) / c
    # the target-size rule only lowers the SNR, and only near a pixel: wider below than above
    assert down[1] > 1.2 * up[1]
    assert down[2] == pytest.approx(up[2], rel=0.25)  # far: a point, symmetric terms only
    assert 0.05 < down[1] < 0.3
    again = predict(MW, UAV1, [250.0, 451.0, 2000.0], background_temp_k=288.15)
    assert np.array_equal(again.lower["small_corrected"], p.lower["small_corrected"])


def test_sky_assumed_equal_to_air_is_said_and_widens_the_band():
    """No sky temperature: the JSON says the sky was assumed equal to the air, and the band
    carries an 8 K sky error (a 1.5-2x swing at 508 m in the MWIR, where the path radiance
    amplifies it), against the 5 % of a measured sky's radiance."""
    assumed = predict(MW, UAV1, [199.0, 508.0])
    measured = predict(MW, UAV1, [199.0, 508.0], background_temp_k=288.15)
    rec = assumed.to_records()[1]
    assert rec["sky_assumed_equal_to_air"] is True and rec["sky_temp_k"] == rec["air_temp_k"]
    assert measured.to_records()[1]["sky_assumed_equal_to_air"] is False
    width = {}
    for name, p in (("assumed", assumed), ("measured", measured)):
        lo, hi = p.lower["small_corrected"], p.upper["small_corrected"]
        width[name] = (hi - lo) / p.snr_small_corrected
    assert np.all(width["assumed"] > 2.0 * width["measured"])
    assert 0.9 < width["assumed"][1] < 1.6  # 16th-84th percentile, relative
    # the deterministic budget too: the path term is 8 K of sky radiance
    rel_a = assumed.relative_uncertainty["small_corrected"]
    rel_m = measured.relative_uncertainty["small_corrected"]
    assert np.all(rel_a > 2.0 * rel_m)


def test_transmission_uncertainty_grows_with_the_path():
    """Beer-Lambert on the band's optical depth: 10 % of -ln(tau_c), so the term is small near
    the camera and large far out, not a flat 3 %."""
    from snrmon.model.uncertainty import UncertaintyBudget

    p = predict(MW, UAV1, [50.0, 500.0, 5000.0], background_temp_k=288.15, band=False)
    od = -np.log(p.transmission_contrast)
    terms = UncertaintyBudget().terms(np.zeros(3), np.zeros(3, bool), od)
    assert terms["transmission"] == pytest.approx(0.10 * od, rel=1e-12)
    assert terms["transmission"][0] < 0.03 < 0.04 < terms["transmission"][1] < 0.08
    assert terms["transmission"][2] > 0.14
    # and the Monte-Carlo band: its relative width grows with range at fixed other terms
    from snrmon.model.montecarlo import InputUncertainty

    only_tau = InputUncertainty(
        outline_area=0, target_temp_k=0, sky_radiance=0, air_temp_k=0, psf_pvf=0, size_rule=0
    )
    q = predict(MW, UAV1, [50.0, 500.0, 5000.0], background_temp_k=288.15, inputs=only_tau)
    lo, hi = q.lower["small_corrected"], q.upper["small_corrected"]
    rel = (hi - lo) / 2 / q.snr_small_corrected
    assert rel[0] < rel[1] < rel[2]
    assert rel == pytest.approx(0.10 * od, rel=0.35)  # the draws' 16-84 % half-width
