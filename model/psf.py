"""Point spread functions as radially symmetric optical transfer functions (OTF), in pixel units.

Frequencies are in cycles per pixel pitch; lengths in pitches. Every PSF is normalised to unit
energy (OTF(0) = 1). Each PSF splits into ``components()``: (weight, otf, cutoff) triples whose
OTF is smooth on [0, cutoff] and ~0 beyond, so quadratures in :mod:`snrmon.model.pvf` stay accurate
(a polychromatic Airy has one cutoff per wavelength).

* :class:`AiryPsf`: diffraction of a clear circular aperture, q = F lambda / pitch; monochromatic
  (one wavelength) or averaged over the band (flat weights in wavelength unless given).
* :class:`GaussianPsf`: a Gaussian of standard deviation ``sigma_px`` (the paper's section 5 fit).
* :class:`AiryGaussianPsf`: Airy convolved with a Gaussian blur (a "real" PSF).
* :class:`TabulatedMtfPsf`: a measured MTF table (cycles/pixel, MTF), zero beyond the table.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

OtfFn = Callable[[np.ndarray], np.ndarray]
Component = tuple[float, OtfFn, float]

# Gaussian MTF exp(-2 pi^2 s^2 f^2) < 1e-12 beyond f = sqrt(ln(1e12) / (2 pi^2)) / s.
_GAUSS_CUT = math.sqrt(math.log(1e12) / (2.0 * math.pi**2))


def _airy_otf(f: np.ndarray, cutoff: float) -> np.ndarray:
    # (2 / pi) (arccos nu - nu sqrt(1 - nu^2)), computed in place (a frequency grid's first
    # evaluation pays for every new array in page faults)
    nu = np.abs(f) / cutoff
    np.clip(nu, 0.0, 1.0, out=nu)
    root = nu * nu
    np.subtract(1.0, root, out=root)
    np.sqrt(root, out=root)
    root *= nu
    out = np.arccos(nu, out=nu)
    out -= root
    out *= 2.0 / math.pi
    return out


def _gauss_mtf(f: np.ndarray, sigma_px: float) -> np.ndarray:
    return np.exp(-2.0 * math.pi**2 * sigma_px**2 * np.asarray(f) ** 2)


def _blurred_otf(f: np.ndarray, otf: OtfFn, sigma_px: float) -> np.ndarray:
    """An OTF times a Gaussian blur's MTF (a cascade of optics and aberration)."""
    return otf(f) * _gauss_mtf(f, sigma_px)


@dataclass(frozen=True)
class GaussianPsf:
    """Gaussian PSF exp(-r^2 / (2 sigma^2)), ``sigma_px`` in pixel pitches (paper section 5's
    fit); ``sigma_px`` 0 is a delta function (a point imaged to a point), which the pixel
    patterns (:func:`snrmon.model.footprint.pixel_patterns`) and the PVF's closed forms
    (:mod:`snrmon.model.pvf`) take directly: it has no band-limited OTF to integrate."""

    sigma_px: float

    def __post_init__(self) -> None:
        if not (self.sigma_px >= 0 and math.isfinite(self.sigma_px)):
            raise ValueError(f"Gaussian PSF sigma_px must be >= 0, got {self.sigma_px!r}")

    def components(self) -> list[Component]:
        s = float(self.sigma_px)
        if s == 0.0:
            raise ValueError(
                "a delta-function PSF (Gaussian sigma 0) has no band-limited OTF: its pixel "
                "patterns and PVF are closed forms, its OTF integrals do not exist"
            )
        return [(1.0, lambda f: _gauss_mtf(f, s), _GAUSS_CUT / s)]


@dataclass(frozen=True)
class AiryPsf:
    """Diffraction-limited PSF of a clear circular aperture.

    ``q_values`` are F lambda / pitch for each wavelength and ``weights`` their (normalised)
    weights; build with :meth:`monochromatic` or :meth:`polychromatic`. The OTF cutoff of one
    wavelength is 1/q cycles per pitch.
    """

    q_values: tuple[float, ...]
    weights: tuple[float, ...] = field(default=())

    def __post_init__(self) -> None:
        if not self.q_values or any(not (q > 0 and math.isfinite(q)) for q in self.q_values):
            raise ValueError(f"Airy PSF needs F*lambda/pitch > 0, got {self.q_values!r}")
        if not self.weights:
            object.__setattr__(
                self, "weights", tuple([1.0 / len(self.q_values)] * len(self.q_values))
            )
        w = np.asarray(self.weights, dtype=float)
        if w.shape != (len(self.q_values),) or np.any(w < 0) or w.sum() <= 0:
            raise ValueError(
                f"Airy PSF weights must be >= 0, one per wavelength, got {self.weights!r}"
            )
        object.__setattr__(self, "weights", tuple(float(x) for x in w / w.sum()))

    @classmethod
    def monochromatic(cls, f_number: float, pitch_um: float, wavelength_um: float) -> AiryPsf:
        """Airy at one wavelength: q = F lambda / pitch."""
        _positive("f_number", f_number)
        _positive("pitch_um", pitch_um)
        _positive("wavelength_um", wavelength_um)
        return cls((f_number * wavelength_um / pitch_um,))

    @classmethod
    def polychromatic(
        cls,
        f_number: float,
        pitch_um: float,
        band_um: tuple[float, float],
        n_wavelengths: int = 15,
        weights: np.ndarray | None = None,
    ) -> AiryPsf:
        """Airy averaged over the band at ``n_wavelengths`` evenly spaced wavelengths (midpoint
        rule), flat in wavelength unless ``weights`` (one per wavelength) are given."""
        _positive("f_number", f_number)
        _positive("pitch_um", pitch_um)
        lo, hi = float(band_um[0]), float(band_um[1])
        if not 0 < lo < hi:
            raise ValueError(f"band must be 0 < lo < hi um, got {band_um!r}")
        wl = band_wavelengths_um((lo, hi), n_wavelengths)
        w = np.ones_like(wl) if weights is None else np.asarray(weights, dtype=float)
        return cls(tuple(float(x) for x in f_number * wl / pitch_um), tuple(float(x) for x in w))

    @property
    def q(self) -> float:
        """Weighted mean F lambda / pitch."""
        return float(np.dot(self.q_values, self.weights))

    def components(self) -> list[Component]:
        out: list[Component] = []
        for q, w in zip(self.q_values, self.weights, strict=True):
            cut = 1.0 / q
            out.append((w, functools.partial(_airy_otf, cutoff=cut), cut))
        return out

    def radial_psf(self, r_px: np.ndarray) -> np.ndarray:
        """PSF intensity per pitch^2 at radius r (unit energy): sum_w (pi/4q^2)[2 J1(x)/x]^2."""
        from scipy.special import j1

        r = np.asarray(r_px, dtype=float)
        out = np.zeros_like(r)
        for q, w in zip(self.q_values, self.weights, strict=True):
            x = math.pi * r / q
            with np.errstate(invalid="ignore", divide="ignore"):
                a = np.where(x > 1e-8, 2.0 * j1(x) / np.where(x > 1e-8, x, 1.0), 1.0)
            out += w * math.pi / (4.0 * q * q) * a * a
        return out


@dataclass(frozen=True)
class AiryGaussianPsf:
    """An Airy PSF convolved with a Gaussian blur of ``sigma_px`` (aberrations, jitter, ...)."""

    airy: AiryPsf
    sigma_px: float

    def __post_init__(self) -> None:
        if not (self.sigma_px >= 0 and math.isfinite(self.sigma_px)):
            raise ValueError(f"blur sigma_px must be >= 0, got {self.sigma_px!r}")

    def components(self) -> list[Component]:
        s = float(self.sigma_px)
        return [
            (w, functools.partial(_blurred_otf, otf=otf, sigma_px=s), cut)
            for w, otf, cut in self.airy.components()
        ]


@dataclass(frozen=True)
class TabulatedMtfPsf:
    """A measured, radially symmetric MTF: ``freq_cy_per_px`` ascending from 0, ``mtf`` with
    MTF(0) = 1; linear interpolation, zero beyond the last frequency (phase assumed zero)."""

    freq_cy_per_px: tuple[float, ...]
    mtf: tuple[float, ...]

    def __post_init__(self) -> None:
        f = np.asarray(self.freq_cy_per_px, dtype=float)
        m = np.asarray(self.mtf, dtype=float)
        if f.ndim != 1 or f.shape != m.shape or f.size < 2:
            raise ValueError("MTF table needs two equal-length columns of at least 2 rows")
        if f[0] != 0.0 or np.any(np.diff(f) <= 0):
            raise ValueError("MTF table frequencies must start at 0 and increase")
        if abs(m[0] - 1.0) > 1e-6 or np.any(m < -1e-9) or np.any(m > 1.0 + 1e-9):
            raise ValueError(f"MTF table must have MTF(0) = 1 and values in [0, 1], got {m[0]}")

    def components(self) -> list[Component]:
        f = np.asarray(self.freq_cy_per_px, dtype=float)
        m = np.asarray(self.mtf, dtype=float)
        return [(1.0, lambda x: np.interp(np.abs(x), f, m, right=0.0), float(f[-1]))]


Psf = GaussianPsf | AiryPsf | AiryGaussianPsf | TabulatedMtfPsf


def band_wavelengths_um(band_um: tuple[float, float], n: int) -> np.ndarray:
    """``n`` midpoints of equal sub-bands of the band [um]."""
    if n < 1:
        raise ValueError(f"number of wavelengths must be >= 1, got {n}")
    lo, hi = float(band_um[0]), float(band_um[1])
    return lo + (np.arange(n) + 0.5) * (hi - lo) / n


def otf(psf: Psf, f_cy_per_px: np.ndarray) -> np.ndarray:
    """The PSF's (radial) OTF at the given spatial frequencies."""
    f = np.asarray(f_cy_per_px, dtype=float)
    return sum((w * fn(f) for w, fn, _ in psf.components()), np.zeros_like(f))


def _positive(name: str, value: float) -> None:
    if not (value > 0 and math.isfinite(value)):
        raise ValueError(f"{name} must be > 0, got {value!r}")
