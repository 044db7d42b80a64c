"""Planck radiometry: spectral and band radiance in power and photon units and their temperature
derivatives (paper Eq. 2 integrates contrast photon radiance over the band).

Units: wavelengths in micrometres at the edges, radiance in W m^-2 sr^-1 (spectral: per um),
photon radiance in photons s^-1 m^-2 sr^-1 (spectral: per um). Band integrals of L and Lq use the
Widger-Woodall series (BAMS 57(10) 1217, 1976), exact to rounding; derivatives and weighted
integrals use Gauss-Legendre quadrature on the band (the integrands are smooth, so 64 nodes give
~1e-14 relative). The tests check both against scipy's adaptive quadrature.
"""

from __future__ import annotations

import functools
import math

import numpy as np

from snrmon.model.constants import C2, SIGMA_SB, C, H

_C1 = 2.0 * H * C * C  # 2hc^2 [W m^2 sr^-1]


def _check_band(band_um: tuple[float, float]) -> tuple[float, float]:
    lo, hi = float(band_um[0]), float(band_um[1])
    if not (0.0 < lo < hi) or not math.isfinite(hi):
        raise ValueError(f"band must be two wavelengths 0 < lo < hi in um, got {band_um!r}")
    return lo, hi


def _check_temp(temp_k: float) -> None:
    if not np.all(np.asarray(temp_k, dtype=float) > 0.0):
        raise ValueError(f"temperature must be > 0 K, got {temp_k!r}")


def _x(wl_um, temp_k):
    return C2 / (np.asarray(wl_um, dtype=float)[..., None] * 1e-6 * np.asarray(temp_k, float))


def spectral_radiance(wl_um, temp_k) -> np.ndarray:
    """Planck L_lambda [W m^-2 sr^-1 um^-1]; broadcasts wl_um (...) against temp_k -> (..., T)."""
    lam = np.asarray(wl_um, dtype=float)[..., None] * 1e-6
    out = _C1 / lam**5 / np.expm1(_x(wl_um, temp_k)) * 1e-6
    return out if np.ndim(temp_k) else out[..., 0]


def spectral_photon_radiance(wl_um, temp_k) -> np.ndarray:
    """Planck Lq_lambda [photons s^-1 m^-2 sr^-1 um^-1] (L_lambda / (hc/lambda))."""
    lam = np.asarray(wl_um, dtype=float)[..., None] * 1e-6
    out = 2.0 * C / lam**4 / np.expm1(_x(wl_um, temp_k)) * 1e-6
    return out if np.ndim(temp_k) else out[..., 0]


def _dlog_dt(wl_um, temp_k):
    x = _x(wl_um, temp_k)
    # d/dT [1/(e^x - 1)] = x e^x / (e^x - 1)^2 / T, written to avoid overflow at large x.
    return x / (-np.expm1(-x)) / np.asarray(temp_k, float)


def spectral_radiance_dt(wl_um, temp_k) -> np.ndarray:
    """dL_lambda/dT [W m^-2 sr^-1 um^-1 K^-1]."""
    lam = np.asarray(wl_um, dtype=float)[..., None] * 1e-6
    out = _C1 / lam**5 / np.expm1(_x(wl_um, temp_k)) * 1e-6 * _dlog_dt(wl_um, temp_k)
    return out if np.ndim(temp_k) else out[..., 0]


def spectral_photon_radiance_dt(wl_um, temp_k) -> np.ndarray:
    """dLq_lambda/dT [photons s^-1 m^-2 sr^-1 um^-1 K^-1]."""
    lam = np.asarray(wl_um, dtype=float)[..., None] * 1e-6
    out = 2.0 * C / lam**4 / np.expm1(_x(wl_um, temp_k)) * 1e-6 * _dlog_dt(wl_um, temp_k)
    return out if np.ndim(temp_k) else out[..., 0]


def _ww_tail(wn_per_m: float, temp_k: float, photons: bool) -> float:
    """Widger-Woodall: integral of Planck radiance from wavenumber ``wn`` [m^-1] to infinity."""
    x = C2 * wn_per_m / temp_k
    if x == 0.0:
        return total_photon_radiance(temp_k) if photons else total_radiance(temp_k)
    n = np.arange(1, int(min(2 + 20.0 / x, 2000)) + 1, dtype=float)
    e = np.exp(-n * x)
    if photons:
        s = np.sum(e * (x * x / n + 2.0 * x / n**2 + 2.0 / n**3))
        return float(2.0 * C * (temp_k / C2) ** 3 * s)
    s = np.sum(e * (x**3 / n + 3.0 * x * x / n**2 + 6.0 * x / n**3 + 6.0 / n**4))
    return float(_C1 * (temp_k / C2) ** 4 * s)


def band_radiance(band_um: tuple[float, float], temp_k: float) -> float:
    """In-band radiance [W m^-2 sr^-1] of a blackbody (Widger-Woodall series)."""
    lo, hi = _check_band(band_um)
    _check_temp(temp_k)
    return _ww_tail(1e6 / hi, temp_k, False) - _ww_tail(1e6 / lo, temp_k, False)


def band_photon_radiance(band_um: tuple[float, float], temp_k: float) -> float:
    """In-band photon radiance [photons s^-1 m^-2 sr^-1] (Widger-Woodall series)."""
    lo, hi = _check_band(band_um)
    _check_temp(temp_k)
    return _ww_tail(1e6 / hi, temp_k, True) - _ww_tail(1e6 / lo, temp_k, True)


@functools.lru_cache(maxsize=64)
def band_nodes(band_um: tuple[float, float], n: int = 64) -> tuple[np.ndarray, np.ndarray]:
    """Gauss-Legendre nodes [um] and weights [um] on the band (for the spectral integrals)."""
    lo, hi = _check_band(band_um)
    x, w = np.polynomial.legendre.leggauss(n)
    nodes = 0.5 * (hi - lo) * x + 0.5 * (hi + lo)
    weights = 0.5 * (hi - lo) * w
    nodes.setflags(write=False)
    weights.setflags(write=False)
    return nodes, weights


def band_radiance_dt(band_um: tuple[float, float], temp_k: float) -> float:
    """d(in-band radiance)/dT [W m^-2 sr^-1 K^-1]."""
    _check_temp(temp_k)
    wl, w = band_nodes(tuple(map(float, band_um)))
    return float(np.sum(w * spectral_radiance_dt(wl, float(temp_k))))


def band_photon_radiance_dt(band_um: tuple[float, float], temp_k: float) -> float:
    """d(in-band photon radiance)/dT [photons s^-1 m^-2 sr^-1 K^-1]."""
    _check_temp(temp_k)
    wl, w = band_nodes(tuple(map(float, band_um)))
    return float(np.sum(w * spectral_photon_radiance_dt(wl, float(temp_k))))


def total_radiance(temp_k: float) -> float:
    """Radiance over all wavelengths, sigma T^4 / pi [W m^-2 sr^-1]."""
    _check_temp(temp_k)
    return SIGMA_SB * float(temp_k) ** 4 / math.pi


def total_photon_radiance(temp_k: float) -> float:
    """Photon radiance over all wavelengths, 2 c zeta(3) 2 (kT/hc)^3 [photons s^-1 m^-2 sr^-1]."""
    _check_temp(temp_k)
    zeta3 = 1.2020569031595942
    return 2.0 * C * 2.0 * zeta3 * (float(temp_k) / C2) ** 3
