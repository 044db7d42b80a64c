"""The digital twin's own optics and drone: independent of the model's PSFs, the
paper's 0.8-px Gaussian fit, the outline's two dimensions, the scenario's sky and air."""

import numpy as np
import pytest

from snrmon.acquisition.calibrate.psf_estimate import StopCrops, estimate_psf
from snrmon.model.footprint import average_pvf_square
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.pvf import average_pvf
from snrmon.sim.optics import TwinOptics, TwinSpread, twin_optics
from snrmon.sim.silhouette import SILHOUETTES, quadcopter, silhouette_for
from snrmon.sim.twin import Scenario, twin_scene_config

MW, LW = load_sensor("mwir"), load_sensor("lwir")
UAV1 = load_target("uav1")


@pytest.mark.parametrize("sensor", [MW, LW])
def test_twin_airy_agrees_with_the_models_by_another_route(sensor):
    """The model's wavelengths and weights and no blur: the spatial-domain twin and the model's
    OTF quadrature give the same average PVF (two independent numerical routes) within 0.5 %."""
    airy = sensor.diffraction_psf()
    wl = tuple(q * sensor.pitch_um / sensor.f_number for q in airy.q_values)
    flat = TwinOptics(sensor.f_number, sensor.pitch_um, sensor.fill_factor, 0.0, wl, airy.weights)
    model = average_pvf(airy, sensor.fill_factor)
    assert flat.average_pvf() == pytest.approx(model, rel=0.005)
    # the far wings beyond 8 px are not rendered: ~3 % (MWIR) and ~2 % (LWIR) of the light
    assert 0.96 * sensor.fill_factor < flat.prf(16).sum() / 256 < sensor.fill_factor


def _point_crops(optics, n=49):
    """Noise-free crops of a point at phases over the cell, peak-centred like the console's."""
    ph = (np.arange(7) + 0.5) / 7 - 0.5
    pats = optics.point_patterns(ph, half_px=6).reshape(-1, 13, 13)
    out = []
    for p in pats:
        r, c = np.unravel_index(int(np.argmax(p)), p.shape)
        big = np.zeros((25, 25))
        big[6:19, 6:19] = p
        out.append(1000.0 * big[r : r + 13, c : c + 13] + 1e-3)
    return np.asarray(out)[:n]


def test_mwir_twin_reproduces_the_papers_gaussian_fit_and_has_its_own_pvf():
    optics = twin_optics(MW, UAV1.temp_k("mwir"), 280.0)
    est = estimate_psf([StopCrops("point", _point_crops(optics), 0.0)], MW, min_frames=10)
    assert est.sigma_px == pytest.approx(0.80, abs=0.02)  # paper section 5
    pvf = optics.average_pvf()
    assert pvf == pytest.approx(0.1415, abs=0.002)
    assert est.pvf == pytest.approx(pvf, rel=0.03)
    # neither the model's diffraction limit nor its 0.082
    assert average_pvf(MW.diffraction_psf(), 0.8) / pvf > 1.65
    assert pvf / average_pvf(MW.corrected_psf(), 0.8) > 1.6


def test_lwir_twin_is_near_diffraction_limited():
    optics = twin_optics(LW, UAV1.temp_k("lwir"), 280.0)
    assert optics.average_pvf() == pytest.approx(average_pvf(LW.diffraction_psf(), 0.9), rel=0.05)


@pytest.mark.parametrize("name", ["uav1", "uav2"])
def test_outline_area_and_box_are_the_papers_dimensions(name):
    target = load_target(name)
    s = SILHOUETTES[name]()
    assert s.area_m2() ** 0.5 == pytest.approx(target.small_m, rel=1e-9)
    assert s.large_m == pytest.approx(target.large_m, rel=1e-9)
    assert min(p.w_m for p in s.parts) > 0.055  # thick enough for the 3x3 opening at 37 m
    cell = 0.001
    cov = s.coverage(cell)
    assert cov.sum() * cell**2 == pytest.approx(target.small_m**2, rel=1e-6)
    n = cov.shape[0]
    axis = (np.arange(n) - n // 2) * cell
    assert abs((cov.sum(axis=0) * axis).sum() / cov.sum()) < 1e-4  # centroid at the origin
    assert silhouette_for(target).name == name
    with pytest.raises(ValueError, match="small < large"):
        quadcopter("x", 0.3, 0.2)


def test_outline_rendering_conserves_light_and_its_pvf_is_the_outlines():
    optics = twin_optics(MW, UAV1.temp_k("mwir"), 280.0)
    spread = TwinSpread(optics, silhouette_for(UAV1), UAV1.small_m)
    for size in (0.6, 1.6, 8.5):
        f = spread.fractions(0.2, -0.1, size)
        # the light on the active areas: FF of it, less the far wings (~3 %) not rendered
        assert 0.96 * MW.fill_factor < f.sum() < MW.fill_factor
    # the outline spreads its light wider than the model's square of the same area
    d = 1.6
    ph = (np.arange(10) + 0.5) / 10 - 0.5
    h = spread.half_size_px(d)
    twin = np.mean([spread.fractions(x, y, d)[h, h] for x in ph for y in ph])
    blur = twin_optics(MW, UAV1.temp_k("mwir"), 280.0, 0.57)
    assert twin < np.mean([blur.point_patterns(ph, 0)[:, :, 0, 0]])
    assert average_pvf_square(MW.corrected_psf(), 0.8, d) < twin  # not the model's 0.082


def test_scenario_sky_and_air_go_into_the_scene():
    cold = twin_scene_config(MW, UAV1, Scenario(sky_temp_k=270.0, air_temp_k=288.15))
    warm = twin_scene_config(MW, UAV1, Scenario(sky_temp_k=270.0, air_temp_k=300.0))
    assert cold.sky_e == warm.sky_e  # the background is the sky's
    assert warm.target.electrons_at(400.0) > cold.target.electrons_at(400.0)  # warmer path
    rec = Scenario().record(("mwir", "lwir"))
    assert rec["sky_temp_k"] == 280.0 and rec["aberration_px"] == {"mwir": 0.57, "lwir": 0.1}
    with pytest.raises(ValueError, match="sky_temp_k"):
        Scenario(sky_temp_k=-1.0)
