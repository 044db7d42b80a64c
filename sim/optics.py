"""The digital twin's own optics: what each simulated camera does to light, independent of what
the model assumes about it.

A :class:`TwinOptics` is a clear circular aperture at the camera's F-number (diffraction, the
Airy pattern at every wavelength of the band, weighted by the target's contrast spectrum through
the camera's response, not flat) convolved with a Gaussian aberration blur, integrated over
each pixel's active area (a centred square of side sqrt(FF); paper Table 1). Everything is done
in the SPATIAL domain on a fine grid (``supersample`` cells per pixel): the Airy intensity
(pi / 4q^2) [2 J1(x) / x]^2, x = pi r / q, q = F lambda / pitch, sampled and summed over
wavelengths; the blur and the pixel box by FFT convolution on that grid; the result is the pixel
response function (PRF): the fraction of a point's light that a pixel collects, versus the
point's offset from the pixel's centre. The model's PSFs (``model.psf``) are OTFs integrated in
the frequency domain; nothing here calls them.

Presets (:data:`TWIN_ABERRATION_PX`): the MWIR twin is aberration-limited, with the blur that
makes a Gaussian fitted to its point images come out at the paper's sigma = 0.8 px (section 5;
the fit is ``acquisition.calibrate.psf_estimate``'s and the test holds it to 0.80 +/- 0.02);
the LWIR twin is near diffraction-limited (F lambda / d = 0.73, section 8) with a small residual
blur. The light of the far Airy wings, outside +/- ``reach_px`` (~3 % in the MWIR), is not
rendered: spread over the hundreds of pixels it would reach, it is below a thousandth of the
noise in any of them (and folding it back in would brighten the core by 3 %).

:class:`TwinSpread` renders the drone's :class:`snrmon.sim.silhouette.Silhouette` through the PRF at
any range and sub-pixel phase (the renderer's spread protocol of :mod:`snrmon.sim.drone`).
"""

from __future__ import annotations

import functools
import math
from collections import OrderedDict
from dataclasses import dataclass

import numpy as np
from scipy.signal import fftconvolve
from scipy.special import j1

from snrmon.sim.silhouette import Silhouette

TWIN_ABERRATION_PX = {"mwir": 0.57, "lwir": 0.10}
"""Gaussian aberration blur [px] of each twin camera (module docstring)."""


@dataclass(frozen=True)
class TwinOptics:
    """One twin camera's optics (module docstring). ``weights`` are the relative spectral
    weights of ``wavelengths_um`` (the contrast spectrum through the response)."""

    f_number: float
    pitch_um: float
    fill_factor: float
    aberration_sigma_px: float
    wavelengths_um: tuple[float, ...]
    weights: tuple[float, ...]
    reach_px: int = 8

    def __post_init__(self) -> None:
        if not (self.f_number > 0 and self.pitch_um > 0 and 0 < self.fill_factor <= 1):
            raise ValueError("twin optics need F-number > 0, pitch > 0 and 0 < FF <= 1")
        if self.aberration_sigma_px < 0:
            raise ValueError(f"aberration blur must be >= 0 px, got {self.aberration_sigma_px}")
        if len(self.wavelengths_um) != len(self.weights) or not self.weights:
            raise ValueError("twin optics need one weight per wavelength")

    def psf(self, supersample: int) -> np.ndarray:
        """The PSF on the fine grid [energy per fine cell], (n, n), centred, n odd."""
        return _psf(self, int(supersample))

    def prf(self, supersample: int) -> np.ndarray:
        """The pixel response function on the fine grid: entry (i, j) is the fraction of a
        point's light that the pixel collects when the point sits (i - c, j - c) / supersample
        pixels from the pixel's centre (rows = y, columns = x)."""
        return _prf(self, int(supersample))

    def point_patterns(self, phases: np.ndarray, half_px: int = 3) -> np.ndarray:
        """Fractions on a (2h+1)^2 window of pixels for a point at each (dx, dy) of the grid
        ``phases`` x ``phases`` [px from the middle pixel's centre]: (n_dy, n_dx, 2h+1, 2h+1)."""
        ss = 16
        prf = self.prf(ss)
        c = prf.shape[0] // 2
        k = np.arange(-half_px, half_px + 1)
        out = np.empty((len(phases), len(phases), k.size, k.size))
        for i, dy in enumerate(phases):
            rows = c + np.rint((k - dy) * ss).astype(int)
            for j, dx in enumerate(phases):
                cols = c + np.rint((k - dx) * ss).astype(int)
                out[i, j] = prf[np.ix_(rows, cols)]
        return out

    def average_pvf(self, phases: int = 32) -> float:
        """The twin's point-source average PVF: the centre pixel's share over phases uniform
        in the cell (what the model calls the average PVF, here rendered)."""
        ph = (np.arange(phases) + 0.5) / phases - 0.5
        return float(self.point_patterns(ph, 0)[:, :, 0, 0].mean())


@functools.lru_cache(maxsize=8)
def _psf(optics: TwinOptics, ss: int) -> np.ndarray:
    half = (optics.reach_px + 2) * ss
    x = np.arange(-half, half + 1) / ss
    r = np.hypot(x[:, None], x[None, :])
    out = np.zeros_like(r)
    w = np.asarray(optics.weights, float)
    w = w / w.sum()
    for lam, weight in zip(optics.wavelengths_um, w, strict=True):
        q = optics.f_number * lam / optics.pitch_um
        arg = math.pi * r / q
        with np.errstate(invalid="ignore", divide="ignore"):
            a = np.where(arg > 1e-9, 2.0 * j1(arg) / np.where(arg > 1e-9, arg, 1.0), 1.0)
        out += weight * math.pi / (4.0 * q * q) * a * a
    out /= ss * ss  # intensity per px^2 -> energy per fine cell
    s = optics.aberration_sigma_px * ss
    if s > 0:
        g = np.arange(-math.ceil(5 * s), math.ceil(5 * s) + 1)
        kernel = np.exp(-0.5 * (g / s) ** 2)
        kernel /= kernel.sum()
        out = fftconvolve(out, kernel[None, :], mode="same")
        out = fftconvolve(out, kernel[:, None], mode="same")
    return out


@functools.lru_cache(maxsize=8)
def _prf(optics: TwinOptics, ss: int) -> np.ndarray:
    psf = optics.psf(ss)
    # the active square of side a = sqrt(FF) px as fine-cell weights (fractional edge cells)
    a = math.sqrt(optics.fill_factor) * ss
    n = math.ceil(a / 2 + 1)
    g = np.arange(-n, n + 1)
    w1 = np.clip(np.minimum(g + 0.5, a / 2) - np.maximum(g - 0.5, -a / 2), 0.0, 1.0)
    prf = fftconvolve(psf, w1[None, :], mode="same")
    prf = fftconvolve(prf, w1[:, None], mode="same")
    c = prf.shape[0] // 2
    h = optics.reach_px * ss
    return np.clip(prf[c - h : c + h + 1, c - h : c + h + 1], 0.0, None)


def contrast_weights(sensor, target_temp_k: float, sky_temp_k: float, n: int = 12):
    """(wavelengths, weights): the band's midpoints and the target-minus-sky photon radiance
    through the camera's response (QE, optics) at each: the spectrum the Airy is averaged
    over (a warm drone against a cold sky is brighter at the band's long end)."""
    from snrmon.sim.radiometry import TwinCamera, photon_radiance

    lo, hi = float(sensor.band_um[0]), float(sensor.band_um[1])
    wl = lo + (np.arange(n) + 0.5) * (hi - lo) / n
    resp = TwinCamera.from_sensor(sensor).quantum_efficiency(wl)
    w = resp * (photon_radiance(wl, target_temp_k) - photon_radiance(wl, sky_temp_k))
    return tuple(float(v) for v in wl), tuple(float(v) for v in np.clip(w, 0.0, None))


def twin_optics(sensor, target_temp_k: float, sky_temp_k: float, aberration_px=None):
    """The twin camera of a model sensor preset: its Table 1 geometry (F-number, pitch, fill
    factor, band) and the twin's own aberration (:data:`TWIN_ABERRATION_PX` by camera name)."""
    blur = TWIN_ABERRATION_PX.get(sensor.name, 0.0) if aberration_px is None else aberration_px
    wl, w = contrast_weights(sensor, target_temp_k, sky_temp_k)
    return TwinOptics(
        float(sensor.f_number),
        float(sensor.pitch_um),
        float(sensor.fill_factor),
        float(blur),
        wl,
        w,
    )


class TwinSpread:
    """The drone's silhouette through the twin's optics (the spread protocol of
    :mod:`snrmon.sim.drone`): ``fractions(dx, dy, size_px)`` with ``size_px`` the small dimension in
    pixels at the current range. One FFT convolution of the rasterised silhouette with the PRF
    per size (cached by 1 % steps, 3 % above 4 px) serves every phase: a phase is a strided
    read of it, rounded to 1/16 px (1/8 px once the drone spans 8 px, 1/4 px from 24 px)."""

    def __init__(self, optics: TwinOptics, silhouette: Silhouette, small_m: float, *, cache=24):
        self.optics = optics
        self.silhouette = silhouette
        self.small_m = float(small_m)
        self._cache: OrderedDict[tuple, tuple[int, np.ndarray]] = OrderedDict()
        self._cache_size = int(cache)

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_cache"] = OrderedDict()  # rebuilt in the rendering process
        return state

    def is_resolved(self, size_px: float) -> bool:
        return size_px > 1.0

    def _extent_px(self, size_px: float) -> float:
        s = self.silhouette
        x0, y0, x1, y1 = s.bbox_m
        return max(abs(x0), abs(x1), abs(y0), abs(y1)) * size_px / self.small_m

    def half_size_px(self, size_px: float) -> int:
        return math.ceil(self._extent_px(size_px)) + self.optics.reach_px

    def _image(self, size_px: float) -> tuple[int, np.ndarray]:
        # finer steps where the drone is small (its sub-pixel shape sets the peak), coarser
        # once it covers many pixels (a close, resolved drone: 2 % of its size, 1/4-px phases)
        step = 1.01 if size_px < 4.0 else 1.03
        key = (step, round(math.log(max(size_px, 1e-6)) / math.log(step)))
        hit = self._cache.get(key)
        if hit is None:
            scale = step ** key[1]  # the bucket's size in px
            extent = self._extent_px(scale)
            ss = 16 if extent < 4 else 8 if extent < 12 else 4
            cell_m = self.small_m / scale / ss  # metres per fine cell
            cov = self.silhouette.coverage(cell_m)
            # the target's light, normalised to 1, spread over the pixels by the PRF
            image = fftconvolve(cov / cov.sum(), self.optics.prf(ss), mode="full")
            hit = (ss, image)
            self._cache[key] = hit
            if len(self._cache) > self._cache_size:
                self._cache.popitem(last=False)
        else:
            self._cache.move_to_end(key)
        return hit

    def fractions(self, dx_px: float, dy_px: float, size_px: float) -> np.ndarray:
        """(2h+1)^2 fractions of the drone's light on the pixels' active areas, rows = y,
        centroid at (dx, dy) px from the middle pixel's centre."""
        ss, image = self._image(size_px)
        h = self.half_size_px(size_px)
        c = image.shape[0] // 2
        k = np.arange(-h, h + 1)
        rows = c + np.rint((k - dy_px) * ss).astype(int)
        cols = c + np.rint((k - dx_px) * ss).astype(int)
        ok_r = (rows >= 0) & (rows < image.shape[0])
        ok_c = (cols >= 0) & (cols < image.shape[1])
        out = np.zeros((k.size, k.size))
        out[np.ix_(ok_r, ok_c)] = image[np.ix_(rows[ok_r], cols[ok_c])]
        return out
