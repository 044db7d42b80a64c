"""The real MODTRAN tape7 files (tests/data/pyradi/tape7: transmittance and thermal radiance
runs, several windows) read by the model, and what the model makes of them checked against a
computation written here from the files' own columns: a plain column split of the rows, the
unit conversion from W cm^-2 sr^-1 (cm^-1)^-1, and band/cell averages as trapezoid integrals of
the samples (not the model's cell matrices)."""

from pathlib import Path

import numpy as np
import pytest

from snrmon.model.atmosphere import Atmosphere
from snrmon.model.modtran import read_tape7
from snrmon.model.radiometry import band_nodes
from tests.model.growth_reference import moved_reference

TAPE7 = Path(__file__).parents[1] / "data" / "pyradi" / "tape7"
TRANSMITTANCE = ["ModTrantape7file", "tape7-01"]  # COMBIN TRANS, two header lines
RADIANCE = ["tape7-02", "tape7-02b", "tape7-03", "tape7-03b", "tape7-05", "tape7-05b"]


def plain_columns(path: Path) -> tuple[list[str], np.ndarray]:
    """The first header row's names and the data rows split on blanks (these files' data rows
    have no blank fields before the columns used here)."""
    lines = path.read_text().splitlines()
    head = next(i for i, s in enumerate(lines) if s.split()[:1] == ["FREQ"])
    rows = []
    for s in lines[head + 1 :]:
        if s.strip().startswith("-9999"):
            break
        parts = s.split()
        if parts and parts[0][0].isdigit():
            rows.append([float(x) for x in parts[:3]])
    return lines[head].split(), np.array(rows)


def trapezoid_mean(x: np.ndarray, y: np.ndarray, lo: float, hi: float) -> float:
    grid = np.linspace(lo, hi, 40001)
    return float(np.trapezoid(np.interp(grid, x, y), grid) / (hi - lo))


@pytest.mark.parametrize("name", TRANSMITTANCE + RADIANCE)
def test_every_real_file_reads_as_its_columns_say(name):
    names, rows = plain_columns(TAPE7 / name)
    sp = read_tape7(TAPE7 / name, 1000.0)
    order = np.argsort(1e4 / rows[:, 0])
    assert np.allclose(sp.wavelength_um, (1e4 / rows[:, 0])[order], rtol=1e-12)
    assert np.allclose(sp.transmission, rows[order, 1], atol=1e-12)
    assert sp.has_radiance == (names[2] == "PTH_THRML")
    if sp.has_radiance:
        # W cm-2 sr-1 (cm-1)-1 -> W m-2 sr-1 um-1: x1e4 per m^2, x nu^2 / 1e4 per um
        nu = rows[order, 0]
        assert np.allclose(sp.path_radiance, rows[order, 2] * nu**2, rtol=1e-12)


def test_band_transmission_is_the_spectrum_averaged_not_sampled():
    """ModTrantape7file: 2000-4000 cm-1 every 1 cm-1 (2.5-5 um), tropical. The band average
    over 3.45-5.0 um is the integral of the spectrum; sampling it at the 48 quadrature nodes
    (what the model did before) misses it by percent, the cell averages do not."""
    sp = read_tape7(TAPE7 / "ModTrantape7file", 1000.0)
    band = (3.45, 5.0)
    truth = trapezoid_mean(sp.wavelength_um, sp.transmission, *band)
    atm = Atmosphere(spectral=sp, band_um=band)
    assert atm.transmission(1000.0) == pytest.approx(truth, abs=2e-4)
    wl, w = band_nodes(band, 48)
    sampled = float(np.interp(wl, sp.wavelength_um, sp.transmission) @ w / np.sum(w))
    assert abs(sampled - truth) > 5 * abs(atm.transmission(1000.0) - truth)
    # per cell too: each node's value is the mean of the spectrum over its own cell
    edges = band[0] + np.concatenate([[0.0], np.cumsum(w)])
    cells = atm.spectral_transmission(1000.0, wl, w)[0]
    for i in (0, 11, 23, 36, 47):
        mean = trapezoid_mean(sp.wavelength_um, sp.transmission, edges[i], edges[i + 1])
        assert cells[i] == pytest.approx(mean, abs=1e-6)
    # another range: each sample moved along the curve of growth before the averaging
    inside = (sp.wavelength_um > band[0] - 0.01) & (sp.wavelength_um < band[1] + 0.01)
    wl = sp.wavelength_um[inside]
    moved = moved_reference(wl, sp.transmission[inside], 1000.0, 2000.0)
    assert atm.transmission(2000.0) == pytest.approx(trapezoid_mean(wl, moved, *band), abs=3e-4)


@pytest.mark.parametrize("name", RADIANCE)
def test_path_source_of_a_radiance_run_is_averaged_per_cell(name):
    """2050-2100 cm-1 (4.76-4.88 um): the cell's source function is its mean path radiance
    over its mean emissivity (1 - tau)."""
    sp = read_tape7(TAPE7 / name, 2000.0)
    lo, hi = sp.wavelength_um[0], sp.wavelength_um[-1]
    wl, w = band_nodes((float(lo), float(hi)), 8)
    atm = Atmosphere(spectral=sp, band_um=(float(lo), float(hi)))
    edges = lo + np.concatenate([[0.0], np.cumsum(w)])
    src = atm.path_source_photon(wl, w)
    hc = 6.62607015e-34 * 299792458.0
    for i in range(wl.size):
        rad = trapezoid_mean(sp.wavelength_um, sp.path_radiance, edges[i], edges[i + 1])
        emis = trapezoid_mean(sp.wavelength_um, 1.0 - sp.transmission, edges[i], edges[i + 1])
        assert src[i] == pytest.approx(rad / emis / (hc / (wl[i] * 1e-6)), rel=1e-6)
