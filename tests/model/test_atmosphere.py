"""Atmosphere: the built-in LOWTRAN7 table for the day's weather, per-cell averaging, grey
factors, MODTRAN tape7 and CSV import."""

from pathlib import Path

import numpy as np
import pytest

from snrmon.model.atmosphere import (
    Atmosphere,
    default_atmosphere,
    effective_extinction_per_km,
    resolve_atmosphere,
)
from snrmon.model.atmosphere_table import SEASONS, Weather, load_table, saturation_density_g_m3
from snrmon.model.modtran import read_spectral_csv, read_tape7
from snrmon.model.presets import load_atmosphere
from snrmon.model.radiometry import band_nodes, spectral_photon_radiance
from tests.model.growth_reference import moved_reference

FIX = Path(__file__).with_name("fixtures")
MW, LW = (3.45, 5.25), (8.0, 12.0)


def table_band_average(weather: Weather, range_m: float, band) -> float:
    """Independent of the model's cells: the table's own spectrum, linear between its 5 cm-1
    samples, integrated over the band by trapezoids on a fine wavelength grid."""
    t = load_table()
    wl = t.wavelength_um[::-1]
    tau = t.transmission(weather, [range_m])[0][::-1]
    grid = np.linspace(band[0], band[1], 20001)
    return float(np.trapezoid(np.interp(grid, wl, tau), grid) / (band[1] - band[0]))


@pytest.mark.parametrize("band", [MW, LW])
@pytest.mark.parametrize("range_m", [37.0, 508.0, 3000.0])
def test_band_average_is_the_integral_of_the_table_spectrum(band, range_m):
    w = Weather(air_temp_c=20.0, rh_percent=60.0)
    atm = resolve_atmosphere(w, band)
    assert atm.transmission(range_m) == pytest.approx(
        table_band_average(w, range_m, band), abs=2e-4
    )


def test_humidity_lowers_both_bands_and_the_season_fills_what_is_not_read():
    dry = Weather(air_temp_c=20.0, rh_percent=20.0)
    humid = Weather(air_temp_c=20.0, rh_percent=90.0)
    for band in (MW, LW):
        t_dry = resolve_atmosphere(dry, band).transmission(500.0)
        t_humid = resolve_atmosphere(humid, band).transmission(500.0)
        assert t_humid < t_dry - 0.05
    # the season's sea-level air where nothing is read: US Standard 15 C, 1013.25 hPa, with
    # LOWTRAN7's rural aerosol at 23 km
    t_k, rh, p, vis, aerosol = Weather().state()
    assert (t_k, p, vis, aerosol) == (288.15, 1013.25, 23.0, "rural") and 40.0 < rh < 50.0
    summer = Weather(season="tropical").state()
    assert summer[0] == pytest.approx(299.7) and summer[1] > 70.0
    # a dew point means the same vapour as the relative humidity it makes at that air
    w = Weather(air_temp_c=20.0, dew_point_c=10.0)
    assert w.water_g_m3 == pytest.approx(
        saturation_density_g_m3(283.15) * 283.15 / 293.15, rel=1e-12
    )


def test_aerosol_is_beer_lambert_and_scales_with_visibility():
    clear = Weather(air_temp_c=15.0, rh_percent=50.0, aerosol="none")
    hazy = Weather(air_temp_c=15.0, rh_percent=50.0, visibility_km=5.0)
    t = load_table()
    extra = t.optical_depth(hazy, [1000.0, 2000.0]) - t.optical_depth(clear, [1000.0, 2000.0])
    assert np.all(extra > 0)
    assert np.allclose(extra[1], 2 * extra[0], rtol=1e-9)  # linear in the path
    ten = Weather(air_temp_c=15.0, rh_percent=50.0, visibility_km=10.0)
    extra10 = t.optical_depth(ten, [1000.0]) - t.optical_depth(clear, [1000.0])
    rule = (3.912 / 10 - 0.01159) / (3.912 / 5 - 0.01159)  # Koschmieder less Rayleigh
    assert np.allclose(extra10[0], rule * extra[0], rtol=1e-9)


def test_bad_met_readings_are_one_clear_error():
    with pytest.raises(ValueError, match="relative humidity must be 0 to 100 %, got 120"):
        Weather(rh_percent=120.0)
    with pytest.raises(ValueError, match="air temperature must be -30 to 45 C"):
        Weather(air_temp_c=60.0)
    with pytest.raises(ValueError, match="not both"):
        Weather(rh_percent=50.0, dew_point_c=5.0)
    with pytest.raises(ValueError, match="dew point 25 C is above the air temperature 20 C"):
        Weather(air_temp_c=20.0, dew_point_c=25.0)
    with pytest.raises(ValueError, match="season must be one of"):
        Weather(season="monsoon")
    with pytest.raises(ValueError, match="visibility"):
        Weather(visibility_km=0.0)


def test_every_standard_atmosphere_is_contrast_weighted_in_the_mwir():
    for season in SEASONS:
        atm = default_atmosphere(MW, season)
        flat, weighted = atm.transmission(508.0), atm.contrast_transmission(508.0)
        # the CO2 band eats the strongest part of a near-ambient target's contrast (most at
        # a warm season's air: 23 % tropical, 3 % subarctic winter)
        assert 0.70 < weighted / flat < 0.99, season
        lw = default_atmosphere(LW, season)
        assert lw.contrast_transmission(508.0) == pytest.approx(lw.transmission(508.0), rel=0.02)


def test_mwir_band_average_is_not_beer_lambert():
    atm = default_atmosphere(MW)
    assert effective_extinction_per_km(atm, 50.0) > 2 * effective_extinction_per_km(atm, 1000.0)


def test_many_ranges_match_the_exact_cells():
    # past RANGE_NODES ranges the cells are computed at log-spaced ranges and interpolated
    wl, w = band_nodes(MW, 48)
    atm = default_atmosphere(MW)
    r = np.geomspace(10.0, 5000.0, 500)
    fast = atm.spectral_transmission(r, wl, w)
    exact = np.vstack([atm.spectral_transmission(r[i : i + 50], wl, w) for i in range(0, 500, 50)])
    assert np.max(np.abs(fast - exact)) < 2e-4


def test_constant_and_aerosol_factors_multiply():
    atm = Atmosphere(constant_tau=0.9).with_aerosol(0.2)
    assert atm.transmission(2000.0) == pytest.approx(0.9 * np.exp(-0.4), rel=1e-12)
    assert Atmosphere().transmission(500.0) == 1.0


def test_path_radiance_is_one_minus_tau_times_air_blackbody_per_cell():
    atm = default_atmosphere(LW)
    wl, w = band_nodes(LW, 48)
    tau = atm.spectral_transmission(500.0, wl, w)[0]
    lq = atm.path_photon_radiance(500.0, wl, weights_um=w)[0]
    assert np.allclose(lq, (1 - tau) * spectral_photon_radiance(wl, 288.15), rtol=1e-12)


def test_tape7_thermal_run_columns_and_units():
    sp = read_tape7(FIX / "tape7_radiance.txt", 1000.0)
    assert sp.has_radiance and np.allclose(sp.transmission, 0.7)
    # the fixture holds (1 - 0.7) x B(290 K) in W cm-2 sr-1 (cm-1)-1: the source is B(290 K),
    # averaged over each node's cell (narrow cells: B is nearly linear across them)
    for band in (MW, LW):
        wl, w = band_nodes(band, 64)
        ratio = sp.path_source_photon(wl, w) / spectral_photon_radiance(wl, 290.0)
        assert np.allclose(ratio, 1.0, atol=3e-3)


def test_tape7_transmittance_run_two_header_lines_and_range_scaling():
    sp = read_tape7(FIX / "tape7_transmittance.txt", 500.0)
    assert not sp.has_radiance
    atm = Atmosphere(spectral=sp)
    # per sample along the LOWTRAN7 table's curve of growth (not tau(L0)^(R/L0), which band
    # model samples do not follow): 0.9 at 500 m, where the fixture is flat, is 0.81 at
    # 1000 m between the table's windows (6-7.5 um: Beer-Lambert) and 0.81-0.85 in the LWIR
    fine = sp.transmission_at_ranges([500.0, 1000.0])
    long = sp.wavelength_um > 6.0
    assert np.allclose(fine[0, long], 0.9, atol=1e-9)
    ref = moved_reference(sp.wavelength_um, sp.transmission, 500.0, 1000.0)
    assert np.allclose(fine[1], ref, atol=2e-4)
    gap = long & (sp.wavelength_um < 7.4)
    assert gap.any() and np.allclose(fine[1, gap], 0.81, atol=1e-9)
    assert np.all(fine[1, long] >= 0.81 - 1e-9) and fine[1, long].max() > 0.83
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
    met = tmp_path / "met.toml"
    met.write_text('[atmosphere]\nmodel = "midlat_summer"\nrh_percent = 30\nair_temp_c = 25\n')
    atm = load_atmosphere(met, LW)
    assert atm.weather == Weather(season="midlat_summer", rh_percent=30.0, air_temp_c=25.0)
    assert atm.air_temp_k == pytest.approx(298.15)


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
    bad_toml.write_text("[atmosphere]\nrh_percent = 150\n")
    with pytest.raises(ValueError, match=r"a.toml: \[atmosphere\] relative humidity"):
        load_atmosphere(bad_toml, MW)


def test_the_default_air_has_a_rural_haze_unless_told_there_is_none():
    """The default atmosphere (no readings) is LOWTRAN7's rural aerosol at 23 km: its
    contrast-weighted transmission 0.7 % below a path without aerosol at 500 m and 2.1-2.2 %
    at 1.5 km in both bands; ``aerosol="none"`` (or a recorded visibility of None) is the clear
    path."""
    for band, at_500, at_1500 in ((MW, 0.9928, 0.9784), (LW, 0.9930, 0.9791)):
        hazy = resolve_atmosphere(None, band)
        clear = resolve_atmosphere(Weather(aerosol="none"), band)
        assert resolve_atmosphere(Weather(visibility_km=None), band).transmission(500.0) == (
            clear.transmission(500.0)
        )
        ranges = [500.0, 1500.0]
        ratio = hazy.contrast_transmission(ranges) / clear.contrast_transmission(ranges)
        assert ratio == pytest.approx([at_500, at_1500], abs=5e-4)
    assert "rural aerosol, visibility 23 km" in Weather().describe()
    assert "no aerosol" in Weather(aerosol="none").describe()
