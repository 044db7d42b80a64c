"""The twin's own radiometry (sim.radiometry) against the model's, written apart: the same
physics from the same data gives the same numbers, except where the two made different
choices (the etendue of an extended scene), by exactly those choices."""

import math

import numpy as np
import pytest
from scipy.integrate import quad

from snrmon.model.atmosphere import default_atmosphere, line_of_sight
from snrmon.model.constants import C2, C, H
from snrmon.model.detector import background_electrons
from snrmon.model.noise import temporal_noise_e
from snrmon.model.presets import load_atmosphere, load_sensor, load_target
from snrmon.model.radiometry import band_photon_radiance
from snrmon.model.snr import target_contrast_electrons
from snrmon.sim.radiometry import TwinCamera, photon_radiance, spectral_bins

MW, LW = load_sensor("mwir"), load_sensor("lwir")
UAV1 = load_target("uav1")


@pytest.mark.parametrize("temp_k", [250.0, 300.0, 340.0])
def test_planck_band_integral_matches_the_series(temp_k):
    """The twin's Planck summed on a fine grid against the model's Widger-Woodall series."""
    for band in ((3.45, 5.25), (8.0, 12.0)):
        wl, dw = spectral_bins(np.linspace(band[0], band[1], 4001), band)
        twin = float(np.sum(photon_radiance(wl, temp_k) * dw))
        assert twin == pytest.approx(band_photon_radiance(band, temp_k), rel=1e-6)


@pytest.mark.parametrize("sensor", [MW, LW])
def test_contrast_agrees_with_the_model_on_the_built_in_atmosphere(sensor):
    """Eq. 2 without the PVF: the twin's sum on a 5 cm^-1 grid and the model's 48-node
    quadrature agree within 1e-4 from 37 to 1000 m (sky 280 K, air 288.15 K)."""
    cam = TwinCamera.from_sensor(sensor)
    atm = default_atmosphere(tuple(sensor.band_um))
    t_target = UAV1.temp_k(sensor.name)
    for r in (37.0, 199.0, 508.0, 1000.0):
        twin = cam.contrast_electrons(
            line_of_sight(atm, r, tuple(sensor.band_um)), t_target, 280.0, UAV1.small_m**2
        )
        model = target_contrast_electrons(
            sensor, UAV1, r, background_temp_k=280.0, air_temp_k=288.15
        )
        assert twin == pytest.approx(model, rel=1e-4), r


@pytest.mark.parametrize("sensor", [MW, LW])
def test_background_and_noise_differ_by_the_etendue_only(sensor):
    """A pixel's scene through the aperture: the twin's sine-condition pi/4F^2 against the
    model's cone pi/(4F^2 + 1); the rest (lens, dark current, cold shield) is small. The
    MWIR's noise is its Poisson charge plus read noise; the bolometer's its NETD, in both."""
    cam = TwinCamera.from_sensor(sensor)
    etendue = (4 * sensor.f_number**2 + 1) / (4 * sensor.f_number**2)
    ratio = cam.pixel_electrons(280.0) / background_electrons(sensor, 280.0)
    assert ratio == pytest.approx(etendue, rel=0.003)
    noise = cam.temporal_noise_e(cam.pixel_electrons(280.0))
    if sensor.detector == "photon":
        assert noise == pytest.approx(math.hypot(100.0, math.sqrt(cam.pixel_electrons(280.0))))
        assert noise / temporal_noise_e(sensor, 280.0) == pytest.approx(1.023, abs=0.002)
    else:  # NETD x responsivity at 300 K, and the responsivity is the signal's geometry
        netd = cam.temporal_noise_e(cam.pixel_electrons(300.0)) / cam.responsivity_e_per_k(300.0)
        assert netd == pytest.approx(sensor.netd_mk * 1e-3, rel=1e-9)
        assert noise / temporal_noise_e(sensor, 280.0) == pytest.approx(1.0, abs=0.001)


def _spectrum_csv(path, path_length_m: float):
    """A MWIR path with a deep, narrow absorption (the CO2 band's shape), its path radiance
    that of air at 288.15 K, on a 0.002-um grid."""
    wl = np.arange(3.0, 5.6, 0.002)
    tau = 0.95 * (1.0 - 0.9 * np.exp(-(((wl - 4.3) / 0.06) ** 2)))
    lam = wl * 1e-6
    b_w = 2 * H * C**2 / lam**5 / np.expm1(C2 / (lam * 288.15)) * 1e-6
    rows = np.column_stack([wl, tau, (1 - tau) * b_w])
    np.savetxt(path, rows, delimiter=",", header="wavelength_um,transmission,path_radiance")
    return wl, tau


def test_a_spectral_atmosphere_is_integrated_at_its_own_resolution(tmp_path):
    """Through the seam the twin gets the table's own grid inside the band, its transmission
    and its path radiance, and sums them bin by bin: the drone's contrast equals an
    integral written here from the definitions (trapezoid on the table, quad for the
    smooth Planck parts) within 1e-3."""
    band = tuple(MW.band_um)
    wl_table, tau_table = _spectrum_csv(tmp_path / "path.csv", 400.0)
    atm = load_atmosphere(tmp_path / "path.csv", band, path_length_m=400.0)
    line = line_of_sight(atm, 400.0, band)
    inside = wl_table[(wl_table >= band[0]) & (wl_table <= band[1])]
    np.testing.assert_allclose(line.wavelength_um, inside)
    assert line.spectral and line.path_radiance_w is not None
    cam = TwinCamera.from_sensor(MW)
    t_drone = UAV1.temp_k("mwir")
    twin = cam.contrast_electrons(line, t_drone, 280.0, UAV1.small_m**2)

    def lq(w, t):
        lam = w * 1e-6
        return 2 * C / lam**4 / np.expm1(C2 / (lam * t)) * 1e-6

    tau = np.interp(inside, wl_table, tau_table)
    through = np.trapezoid(tau * (lq(inside, t_drone) - lq(inside, 288.15)), inside)
    path_and_sky = quad(lambda w: lq(w, 288.15) - lq(w, 280.0), *band)[0]
    k = cam.aperture_area_m2 * MW.t_int_s * UAV1.small_m**2 / 400.0**2 * cam.response(4.0)
    assert twin == pytest.approx(float(k * (through + path_and_sky)), rel=1e-3)
