"""How far the model's band integration is from the spectral truth (docs/model.md, "Band model
against the spectral truth"): the signal through the air computed on the LOWTRAN7 table's own
5 cm-1 spectrum (the truth, integrated here by trapezoids on a fine wavelength grid) against
(a) the model's 48 quadrature cells (each the spectrum's average over its cell) and (b) a grey
band model, the flat band-average transmission times the contrast integral. At three ranges and
three humidities, for both cameras and the UAV1 target."""

import numpy as np
import pytest

from snrmon.model.atmosphere import resolve_atmosphere
from snrmon.model.atmosphere_table import Weather, load_table
from snrmon.model.contrast import contrast
from snrmon.model.presets import load_sensor, load_target
from snrmon.model.radiometry import spectral_photon_radiance

UAV1 = load_target("uav1")
RANGES = [100.0, 500.0, 2000.0]


def effective_transmissions(sensor_name: str, rh: float) -> dict[str, np.ndarray]:
    sensor = load_sensor(sensor_name)
    weather = Weather(air_temp_c=20.0, rh_percent=rh, aerosol="none")  # as docs/model.md says
    band = tuple(sensor.band_um)
    c = contrast(sensor, UAV1, RANGES, atmosphere=weather)
    # truth: the table's spectrum, linear between its samples, on a fine wavelength grid
    t = load_table()
    wl_fine = t.wavelength_um[::-1]
    grid = np.linspace(band[0], band[1], 40001)
    tau = np.array([np.interp(grid, wl_fine, row[::-1]) for row in t.transmission(weather, RANGES)])
    d_lq = spectral_photon_radiance(grid, c.target_temp_k) - spectral_photon_radiance(
        grid, c.air_temp_k
    )
    weight = sensor.qe_at(grid) * d_lq  # tau_optics tau_cold_filter are flat: they cancel
    truth = np.trapezoid(tau * weight, grid, axis=1) / np.trapezoid(weight, grid)
    k = c.k_spec * (spectral_photon_radiance(c.wavelengths_um, c.target_temp_k) - c.source_air)
    model = c.tau @ k / np.sum(k)
    flat = resolve_atmosphere(weather, band).transmission(RANGES)
    return {"truth": truth, "model": model, "grey": np.asarray(flat)}


@pytest.mark.parametrize("sensor", ["mwir", "lwir"])
@pytest.mark.parametrize("rh", [20.0, 50.0, 90.0])
def test_model_cells_follow_the_spectrum_and_a_grey_band_does_not(sensor, rh):
    e = effective_transmissions(sensor, rh)
    model_err = e["model"] / e["truth"] - 1
    grey_err = e["grey"] / e["truth"] - 1
    assert np.all(np.abs(model_err) < 1e-4)  # measured: <= 5e-5
    if sensor == "mwir":  # the CO2 band eats the warm target's strongest contrast
        assert np.all(grey_err > 0.02) and np.all(np.diff(grey_err) > 0)
        assert grey_err[1] > 0.10  # 500 m: +10 % (RH 20) to +26 % (RH 90)
    else:  # nearly grey: within 0.5 %
        assert np.all(np.abs(grey_err) < 0.005)
