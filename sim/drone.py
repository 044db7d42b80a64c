"""The drone as seen by one camera: a finite-size source convolved with the PSF, on pixels.

Owns the noise-free spread of the drone's signal electrons over a small window of pixels:
the fraction of the target (x) PSF energy that lands on each pixel's *active* area (an area fill
factor FF, a centred square of side sqrt(FF) pitches), for a centroid at a sub-pixel offset
(dx, dy) from the middle pixel's centre. Summed over the window this is at most FF-ish and its
mean over uniform phases at the brightest pixel is the average PVF of the model (paper Eq. 2,
section 8; docs/simulation.md).

Shape of the source (the model's convention, docs/model.md):

* unresolved (characteristic dimension D <= ``resolved_above_px`` pixels): Gaussian target of
  sigma_t = D / 2, so with a Gaussian PSF the blur is Gaussian with sqrt(sigma_psf**2 + sigma_t**2);
* resolved: a square box of side D (area D**2, the characteristic area) convolved with the
  Gaussian PSF, integrated exactly over the active areas.

Both are separable products of closed forms (erf and its integral), so a window costs
microseconds. A real (non-Gaussian) PSF from ``model/`` plugs in through :class:`TabulatedSpread`.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr

_SQRT_2PI = math.sqrt(2.0 * math.pi)


def window_half_size_px(size_px: float, psf_sigma_px: float, minimum: int = 3) -> int:
    """Half size h of the (2h+1)^2 window that holds all but ~1e-5 of the source energy."""
    return max(minimum, math.ceil(0.5 * max(size_px, 0.0) + 4.5 * psf_sigma_px + 1.0))


def _edges(half: int, offset_px: float, fill_factor: float) -> tuple[np.ndarray, np.ndarray]:
    """Active-area edges of pixels -half..half relative to a source at ``offset_px``."""
    a = math.sqrt(fill_factor)
    centres = np.arange(-half, half + 1, dtype=np.float64) - offset_px
    return centres - 0.5 * a, centres + 0.5 * a


def gaussian_fractions_1d(half: int, offset_px: float, sigma_px: float, fill_factor: float):
    """Fraction of a 1-D Gaussian (sigma_px) on each pixel's active interval."""
    lo, hi = _edges(half, offset_px, fill_factor)
    s = max(sigma_px, 1e-6)
    return ndtr(hi / s) - ndtr(lo / s)


def box_gaussian_fractions_1d(
    half: int, offset_px: float, size_px: float, sigma_px: float, fill_factor: float
):
    """Fraction of a box of width size_px convolved with a Gaussian on each active interval.

    The profile is [Phi((x+D/2)/s) - Phi((x-D/2)/s)] / D and the integral of Phi(x/s) is
    G(x) = x Phi(x/s) + s phi(x/s), so each pixel is a sum of four G terms.
    """
    lo, hi = _edges(half, offset_px, fill_factor)
    s = max(sigma_px, 1e-6)

    def g(x: np.ndarray) -> np.ndarray:
        return x * ndtr(x / s) + s * np.exp(-0.5 * (x / s) ** 2) / _SQRT_2PI

    d = size_px / 2.0
    return (g(hi + d) - g(lo + d) - g(hi - d) + g(lo - d)) / size_px


@dataclass(frozen=True)
class GaussianSpread:
    """Target (x) Gaussian-PSF energy on pixel active areas; see the module docstring."""

    psf_sigma_px: float
    fill_factor: float
    resolved_above_px: float = 1.0

    def __post_init__(self) -> None:
        if not 0.0 < self.fill_factor <= 1.0:
            raise ValueError(f"fill factor must be in (0, 1], got {self.fill_factor}")
        if self.psf_sigma_px <= 0:
            raise ValueError(f"PSF sigma must be > 0 px, got {self.psf_sigma_px}")

    def is_resolved(self, size_px: float) -> bool:
        return size_px > self.resolved_above_px

    def half_size_px(self, size_px: float) -> int:
        return window_half_size_px(size_px, self.psf_sigma_px)

    def fractions(self, dx_px: float, dy_px: float, size_px: float) -> np.ndarray:
        """(2h+1, 2h+1) energy fractions, rows = y; centroid at (dx, dy) from the middle pixel."""
        h = self.half_size_px(size_px)
        if self.is_resolved(size_px):
            fx = box_gaussian_fractions_1d(h, dx_px, size_px, self.psf_sigma_px, self.fill_factor)
            fy = box_gaussian_fractions_1d(h, dy_px, size_px, self.psf_sigma_px, self.fill_factor)
        else:
            s = math.hypot(self.psf_sigma_px, 0.5 * max(size_px, 0.0))
            fx = gaussian_fractions_1d(h, dx_px, s, self.fill_factor)
            fy = gaussian_fractions_1d(h, dy_px, s, self.fill_factor)
        return np.outer(fy, fx)


class TabulatedSpread:
    """Energy fractions from any function of (dx, dy, target_sigma_px), tabulated over phases.

    ``fractions_fn(dx, dy, target_sigma_px) -> (2h+1, 2h+1)``, e.g. a partial of the model's
    ``model.pvf.pixel_energy_fractions`` with a real PSF. Unresolved sources are looked up on a
    ``phases`` x ``phases`` grid of sub-pixel offsets (nearest cell centre, i.e. phase error
    <= 1/(2*phases) px) for a grid of target sizes (linear in size); resolved sources use
    ``resolved`` (a :class:`GaussianSpread` of equivalent blur), since the model's function only
    knows Gaussian targets. The table is built lazily, once, in the process that renders.
    """

    def __init__(
        self,
        fractions_fn: Callable[[float, float, float], np.ndarray],
        resolved: GaussianSpread,
        *,
        phases: int = 16,
        sizes_px: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0),
    ):
        self.fractions_fn = fractions_fn
        self.resolved = resolved
        self.phases = int(phases)
        self.sizes_px = tuple(float(s) for s in sizes_px)
        self._table: np.ndarray | None = None

    def is_resolved(self, size_px: float) -> bool:
        return self.resolved.is_resolved(size_px)

    def half_size_px(self, size_px: float) -> int:
        if self.is_resolved(size_px):
            return self.resolved.half_size_px(size_px)
        return (self._get_table().shape[-1] - 1) // 2

    def _get_table(self) -> np.ndarray:
        if self._table is None:
            n = self.phases
            centres = (np.arange(n) + 0.5) / n - 0.5
            rows = []
            for size in self.sizes_px:
                plane = [
                    [np.asarray(self.fractions_fn(dx, dy, 0.5 * size)) for dx in centres]
                    for dy in centres
                ]
                rows.append(plane)
            self._table = np.asarray(rows, dtype=np.float64)
        return self._table

    def fractions(self, dx_px: float, dy_px: float, size_px: float) -> np.ndarray:
        if self.is_resolved(size_px):
            return self.resolved.fractions(dx_px, dy_px, size_px)
        table = self._get_table()
        n = self.phases
        ix = min(n - 1, max(0, math.floor((dx_px + 0.5) * n)))
        iy = min(n - 1, max(0, math.floor((dy_px + 0.5) * n)))
        sizes = np.asarray(self.sizes_px)
        s = float(np.clip(size_px, sizes[0], sizes[-1]))
        k = int(np.clip(np.searchsorted(sizes, s) - 1, 0, len(sizes) - 2))
        w = (s - sizes[k]) / (sizes[k + 1] - sizes[k])
        return (1.0 - w) * table[k, iy, ix] + w * table[k + 1, iy, ix]

    def __getstate__(self) -> dict:
        state = self.__dict__.copy()
        state["_table"] = None  # rebuilt in the rendering process
        return state


@dataclass(frozen=True)
class DronePatch:
    """Noise-free drone signal [e-] on a window of pixels; (row0, col0) is its top-left pixel."""

    electrons: np.ndarray
    row0: int
    col0: int


def drone_patch(spread, x_px: float, y_px: float, size_px: float, total_e: float) -> DronePatch:
    """The drone's electrons around image position (x_px, y_px) (x = column, y = row; pixel
    centres at integers). ``spread`` is a :class:`GaussianSpread` or :class:`TabulatedSpread`."""
    if not (math.isfinite(x_px) and math.isfinite(y_px)):
        raise ValueError(f"drone position must be finite, got ({x_px}, {y_px})")
    if total_e < 0:
        raise ValueError(f"drone signal must be >= 0 electrons, got {total_e}")
    cx, cy = round(x_px), round(y_px)
    frac = spread.fractions(x_px - cx, y_px - cy, size_px)
    h = (frac.shape[0] - 1) // 2
    return DronePatch((total_e * frac).astype(np.float32), cy - h, cx - h)
