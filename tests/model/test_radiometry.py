"""Planck band integrals against scipy quadrature and an independently computed table
(agreeing with pyradi's planckInt)."""

import math

import pytest
from scipy.integrate import quad

from snrmon.model import radiometry as rad
from snrmon.model.constants import SIGMA_SB

# independently computed (adaptive quadrature and the Widger-Woodall series; pyradi agrees)
TABLE = [
    ((3.45, 5.25), 250, 0.326056, 7.80615e18, 1.59041e-2, 3.77861e17),
    ((3.45, 5.25), 290, 1.775611, 4.19122e19, 6.53841e-2, 1.52927e18),
    ((3.45, 5.25), 300, 2.536418, 5.96725e19, 8.75970e-2, 2.04134e18),
    ((3.45, 5.25), 320, 4.857594, 1.13558e20, 1.48481e-1, 3.43616e18),
    ((8.0, 12.0), 250, 14.55930, 7.41152e20, 0.336949, 1.69370e19),
    ((8.0, 12.0), 290, 32.51686, 1.63858e21, 0.567236, 2.82223e19),
    ((8.0, 12.0), 300, 38.50042, 1.93596e21, 0.629704, 3.12640e19),
    ((8.0, 12.0), 320, 52.37035, 2.62320e21, 0.757847, 3.74828e19),
]


@pytest.mark.parametrize(("band", "t", "radiance", "lq", "dl", "dlq"), TABLE)
def test_band_values_match_verified_table(band, t, radiance, lq, dl, dlq):
    assert rad.band_radiance(band, t) == pytest.approx(radiance, rel=5e-6)
    assert rad.band_photon_radiance(band, t) == pytest.approx(lq, rel=5e-6)
    assert rad.band_radiance_dt(band, t) == pytest.approx(dl, rel=2e-5)
    assert rad.band_photon_radiance_dt(band, t) == pytest.approx(dlq, rel=2e-5)


@pytest.mark.parametrize("band", [(3.45, 5.25), (8.0, 12.0), (1.0, 20.0)])
@pytest.mark.parametrize("t", [200.0, 300.0, 1000.0])
def test_series_and_gauss_legendre_match_adaptive_quadrature(band, t):
    ref_l = quad(lambda w: float(rad.spectral_radiance(w, t)), *band, epsabs=0, epsrel=1e-12)[0]
    ref_q = quad(lambda w: float(rad.spectral_photon_radiance(w, t)), *band, epsrel=1e-12)[0]
    ref_d = quad(lambda w: float(rad.spectral_photon_radiance_dt(w, t)), *band, epsrel=1e-12)[0]
    assert rad.band_radiance(band, t) == pytest.approx(ref_l, rel=1e-9)
    assert rad.band_photon_radiance(band, t) == pytest.approx(ref_q, rel=1e-9)
    assert rad.band_photon_radiance_dt(band, t) == pytest.approx(ref_d, rel=1e-7)


def test_derivative_matches_finite_difference():
    band, t, h = (3.45, 5.25), 300.0, 1e-3
    fd = (rad.band_radiance(band, t + h) - rad.band_radiance(band, t - h)) / (2 * h)
    assert rad.band_radiance_dt(band, t) == pytest.approx(fd, rel=1e-7)


def test_total_radiance_is_sigma_t4_over_pi_and_the_series_converges_to_it():
    assert rad.total_radiance(300.0) == pytest.approx(SIGMA_SB * 300.0**4 / math.pi, rel=1e-15)
    assert rad.band_radiance((0.05, 1e5), 300.0) == pytest.approx(rad.total_radiance(300), rel=1e-5)
    assert rad.band_photon_radiance((0.05, 1e5), 300.0) == pytest.approx(
        rad.total_photon_radiance(300.0), rel=1e-4
    )


def test_bad_band_and_temperature_are_refused():
    with pytest.raises(ValueError, match="band"):
        rad.band_radiance((5.0, 3.0), 300)
    with pytest.raises(ValueError, match="temperature"):
        rad.band_photon_radiance((3.0, 5.0), -1.0)
