"""Pulse visibility factor (PVF) and ensquared energy (paper sections 2 and 8).

Definitions (lengths in pixel pitches; the active detector is a centred square of side
sqrt(FF), FF an AREA fill factor; PSF normalised to unit energy; a finite target is a Gaussian of
standard deviation ``target_sigma_px`` convolved with the PSF, same total flux):

* ensquared energy: fraction of the energy on the active area with the PSF centred on it (the
  maximum PVF);
* average PVF: the mean, over PSF-centre positions uniform across one pixel cell, of the fraction
  of the energy on that pixel's active area. In the frequency domain (f in cycles/pitch)
  ``PVF = integral OTF(f) FF sinc(a fx) sinc(a fy) sinc(fx) sinc(fy) df`` with a = sqrt(FF).

Gaussian PSFs use closed forms (erf); other PSFs integrate their OTF: polar Gauss-Legendre
(:mod:`snrmon.model.quadrature`) for the averages, a Cartesian trapezoid grid (exact up to
aliasing at a 128-pixel period, by Poisson summation) for :func:`pixel_energy_fractions`.
:func:`average_pvf_spatial` is an independent spatial-domain integration used to check the Airy
values.
"""

from __future__ import annotations

import functools
import itertools
import math

import numpy as np
from scipy.optimize import brentq
from scipy.special import ndtr

from snrmon.model.psf import AiryGaussianPsf, AiryPsf, GaussianPsf, Psf
from snrmon.model.quadrature import gauss_legendre

_SQ2PI = math.sqrt(2.0 * math.pi)
_N_R, _N_THETA = 96, 24


def _check_ff(fill_factor: float) -> float:
    ff = float(fill_factor)
    if not 0.0 < ff <= 1.0:
        raise ValueError(f"fill factor (area) must be in (0, 1], got {fill_factor!r}")
    return ff


def _check_sigma_t(target_sigma_px) -> np.ndarray:
    s = np.asarray(target_sigma_px, dtype=float)
    if np.any(~np.isfinite(s)) or np.any(s < 0):
        raise ValueError(f"target sigma must be >= 0 px, got {target_sigma_px!r}")
    return s


def _g_int(z):
    """Antiderivative of the normal CDF: z Phi(z) + phi(z)."""
    return z * ndtr(z) + np.exp(-0.5 * z * z) / _SQ2PI


def gaussian_pvf_1d(sigma_px, side: float):
    """Closed form of the 1-D average fraction of a Gaussian on an interval of length ``side``,
    centre uniform over one pitch: integral of g(u) * overlap(u) du (u in pitches)."""
    s = np.asarray(sigma_px, dtype=float)
    a = float(side)
    w = np.where(s > 0, s, 1.0)  # sigma 0 (a delta PSF): the overlap at the centre, min(a, 1)
    out = w * (
        _g_int((a + 1) / (2 * w))
        - _g_int((a - 1) / (2 * w))
        - _g_int((1 - a) / (2 * w))
        + _g_int(-(a + 1) / (2 * w))
    )
    return np.where(s > 0, out, min(a, 1.0))


def _gauss_sigma(psf: GaussianPsf, target_sigma_px) -> np.ndarray:
    return np.sqrt(psf.sigma_px**2 + _check_sigma_t(target_sigma_px) ** 2)


@functools.lru_cache(maxsize=64)
def _polar_weights(psf: Psf, fill_factor: float, averaged: bool) -> tuple[np.ndarray, np.ndarray]:
    """Nodes |f| and weights W so that PVF (or EE) = sum W exp(-2 pi^2 sigma_t^2 f^2)."""
    a = math.sqrt(fill_factor)
    xr, wr = gauss_legendre(_N_R)
    xt, wt = gauss_legendre(_N_THETA)
    theta = (xt + 1.0) * math.pi / 8.0
    w_theta = wt * math.pi / 8.0
    fs, ws = [], []
    for weight, otf_fn, cut in psf.components():
        r = (xr + 1.0) * 0.5 * cut
        w_r = wr * 0.5 * cut
        fx = r[:, None] * np.cos(theta)[None, :]
        fy = r[:, None] * np.sin(theta)[None, :]
        g = fill_factor * np.sinc(a * fx) * np.sinc(a * fy)
        if averaged:
            g = g * np.sinc(fx) * np.sinc(fy)
        w = 8.0 * weight * otf_fn(r)[:, None] * r[:, None] * w_r[:, None] * w_theta[None, :] * g
        # a Gaussian target's factor depends on |f| alone: one weight per radius
        fs.append(r)
        ws.append(w.sum(axis=1))
    return np.concatenate(fs), np.concatenate(ws)


def _otf_integral(psf: Psf, fill_factor: float, target_sigma_px, averaged: bool):
    s = _check_sigma_t(target_sigma_px)
    if isinstance(psf, AiryGaussianPsf):
        # Airy (x) blur: the blur's MTF is a Gaussian target's, on the Airy's own nodes (its
        # components keep the Airy's cutoffs), so the Airy's weights serve every blur
        # (the blur solve of a "real" PSF asks for dozens)
        s = np.hypot(s, float(psf.sigma_px))
        psf = psf.airy
    f, w = _polar_weights(psf, _check_ff(fill_factor), averaged)
    if s.ndim == 0:
        if s == 0:
            return float(np.sum(w))
        return float(np.dot(w, np.exp(-2.0 * math.pi**2 * float(s) ** 2 * f * f)))
    return np.exp(-2.0 * math.pi**2 * s.reshape(-1, 1) ** 2 * f[None, :] ** 2) @ w


def average_pvf(psf: Psf, fill_factor: float, target_sigma_px: float = 0.0) -> float:
    """Average PVF of ``psf`` (convolved with a Gaussian target of ``target_sigma_px``)."""
    ff = _check_ff(fill_factor)
    if isinstance(psf, GaussianPsf):
        return float(gaussian_pvf_1d(_gauss_sigma(psf, target_sigma_px), math.sqrt(ff)) ** 2)
    return _otf_integral(psf, ff, target_sigma_px, averaged=True)


def ensquared_energy(psf: Psf, fill_factor: float, target_sigma_px: float = 0.0) -> float:
    """Fraction of the energy on the active area with the PSF centred on the pixel."""
    ff = _check_ff(fill_factor)
    if isinstance(psf, GaussianPsf):
        s = float(_gauss_sigma(psf, target_sigma_px))
        return 1.0 if s == 0.0 else float((2.0 * ndtr(math.sqrt(ff) / (2.0 * s)) - 1.0) ** 2)
    return _otf_integral(psf, ff, target_sigma_px, averaged=False)


@functools.lru_cache(maxsize=64)
def _pvf_table(psf: Psf, fill_factor: float, sigma_max: float) -> tuple[np.ndarray, np.ndarray]:
    grid = np.linspace(0.0, sigma_max, 257)
    return grid, np.asarray(_otf_integral(psf, fill_factor, grid, averaged=True))


def average_pvf_vs_target_sigma(psf: Psf, fill_factor: float, target_sigma_px) -> np.ndarray:
    """Vectorised :func:`average_pvf` over an array of target sigmas. Non-Gaussian PSFs use a
    cached 257-point table (linear interpolation error < 1e-6), so repeated calls are cheap."""
    ff = _check_ff(fill_factor)
    s = _check_sigma_t(target_sigma_px)
    if isinstance(psf, GaussianPsf):
        return gaussian_pvf_1d(_gauss_sigma(psf, s), math.sqrt(ff)) ** 2
    if s.size == 0:
        return np.zeros(s.shape)
    top = float(np.max(s))
    sigma_max = max(0.5, 2.0 ** math.ceil(math.log2(top))) if top > 0 else 0.5
    grid, values = _pvf_table(psf, ff, sigma_max)
    return np.interp(s, grid, values)


def average_pvf_spatial(psf: AiryPsf | GaussianPsf, fill_factor: float, n: int = 160) -> float:
    """Average PVF by spatial-domain integration: integral PSF(u) T(ux) T(uy) du, T the overlap
    of the active interval with a unit cell shifted by u (the check on the OTF route)."""
    ff = _check_ff(fill_factor)
    a = math.sqrt(ff)
    x, w = np.polynomial.legendre.leggauss(n)
    edges = [0.0, (1.0 - a) / 2.0, (1.0 + a) / 2.0]
    us, ws = [], []
    for lo, hi in itertools.pairwise(edges):
        us.append(0.5 * (hi - lo) * x + 0.5 * (hi + lo))
        ws.append(0.5 * (hi - lo) * w)
    u, wu = np.concatenate(us), np.concatenate(ws)
    overlap = np.clip(np.minimum(a / 2, u + 0.5) - np.maximum(-a / 2, u - 0.5), 0.0, None)
    r = np.hypot(u[:, None], u[None, :])
    if isinstance(psf, GaussianPsf):
        density = np.exp(-0.5 * (r / psf.sigma_px) ** 2) / (2 * math.pi * psf.sigma_px**2)
    else:
        density = psf.radial_psf(r)
    return float(4.0 * np.einsum("i,j,ij->", wu * overlap, wu * overlap, density))


def pixel_energy_fractions(
    psf: Psf,
    dx_px: float,
    dy_px: float,
    *,
    half_size_px: int = 3,
    fill_factor: float,
    target_sigma_px: float = 0.0,
) -> np.ndarray:
    """Fractions of the (target (x) PSF) energy on each pixel's ACTIVE area, shape (2h+1, 2h+1),
    rows = y, columns = x, with the centroid at (dx, dy) pixels from the centre of the middle
    pixel. Averaged over uniform (dx, dy) in [-0.5, 0.5)^2 the middle value is
    :func:`average_pvf`. Gaussian PSFs are closed-form; others use a cached frequency grid."""
    ff = _check_ff(fill_factor)
    h = int(half_size_px)
    if h < 0:
        raise ValueError(f"half_size_px must be >= 0, got {half_size_px!r}")
    st = float(_check_sigma_t(target_sigma_px))
    from snrmon.model.footprint import pixel_patterns

    return pixel_patterns(psf, ff, dx_px, dy_px, half_size_px=h, target_sigma_px=st)[0, 0]


def solve_blur_sigma(
    measured_pvf: float,
    fill_factor: float,
    *,
    base_psf: AiryPsf | None = None,
    target_sigma_px: float = 0.0,
) -> float:
    """The Gaussian blur sigma [px] whose PSF (Gaussian alone, or ``base_psf`` (x) Gaussian)
    gives ``measured_pvf`` as its average PVF. Raises ValueError if no blur can give it."""
    ff = _check_ff(fill_factor)

    def pvf(sigma: float) -> float:
        if base_psf is None:
            return average_pvf(GaussianPsf(sigma), ff, target_sigma_px)
        return average_pvf(AiryGaussianPsf(base_psf, sigma), ff, target_sigma_px)

    lo, hi = 1e-4, 50.0
    top = pvf(lo)
    if not 0.0 < measured_pvf < top:
        raise ValueError(
            f"average PVF {measured_pvf!r} cannot be reached by blurring: it must lie in "
            f"(0, {top:.4f}) for fill factor {ff}"
        )
    return float(brentq(lambda s: pvf(s) - measured_pvf, lo, hi, xtol=1e-10, rtol=1e-12))
