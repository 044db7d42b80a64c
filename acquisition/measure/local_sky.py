"""The local sky around a target: its level, its noise, its tilt.

Helpers of :mod:`snrmon.acquisition.measure.blob`, on a float window of the frame:

- :func:`robust_sigma`: the pixel noise from horizontal neighbour differences, 1.4826 MAD /
  sqrt(2): smooth gradients and a small object barely move it.
- :func:`darkest_side_level`: the lowest of the medians of the four sides of the window's
  border ring: on clear sky the sky's level; beside a treeline or a cloud bank the sky's rather
  than a mix of both.
- :func:`flatten_sky`: removes the tilt of a sloping sky (an AGC'd video's dark band above a
  treeline, the sky's elevation gradient) from the pixels that belong to the sky, so that a
  faint object is not joined to a brighter part of the same sky by the slope alone.
- :func:`median`: np.median without its overhead (ten times the work on these small arrays).
"""

from __future__ import annotations

import functools
import math

import numpy as np


@functools.lru_cache(maxsize=64)
def _grid(h: int, w: int) -> tuple[np.ndarray, np.ndarray]:
    """Column and row offsets from a window's centre (read-only)."""
    gx = np.broadcast_to(np.arange(w) - (w - 1) / 2.0, (h, w))
    gy = np.broadcast_to((np.arange(h) - (h - 1) / 2.0)[:, None], (h, w))
    return gx, gy


def flatten_sky(v: np.ndarray, sigma: float) -> bool:
    """Flatten a sloping sky in place: fit a plane to the darker half of the window (the sky,
    not the object or a treeline) and remove its tilt from the pixels that lie within 3 sigma of
    it, keeping the level at the window's centre. Pixels above the sky (the object, clutter,
    saturated plateaus) keep their values. A tilt below 2 sigma across the window is left
    alone; returns whether anything changed."""
    h, w = v.shape
    if v.size < 9:
        return False
    low = v <= median(v.ravel())
    n = int(np.count_nonzero(low))
    if n < 6:
        return False
    gx, gy = _grid(h, w)
    xs, ys, z = gx[low], gy[low], v[low].astype(np.float64)
    a = np.array(
        [
            [n, xs.sum(), ys.sum()],
            [xs.sum(), (xs * xs).sum(), (xs * ys).sum()],
            [ys.sum(), (xs * ys).sum(), (ys * ys).sum()],
        ]
    )
    b = np.array([z.sum(), (xs * z).sum(), (ys * z).sum()])
    try:
        level, tx, ty = np.linalg.solve(a, b)
    except np.linalg.LinAlgError:
        return False
    if (abs(tx) * (w - 1) + abs(ty) * (h - 1)) / 2.0 < 2.0 * sigma:
        return False
    tilt = (tx * gx + ty * gy).astype(np.float32)
    sky = v - tilt < level + 3.0 * sigma
    v[sky] -= tilt[sky]
    return True


def median(values: np.ndarray) -> float:
    """Median of a 1-D float array (np.median's overhead is ten times the work here)."""
    n = values.size
    k = n // 2
    if n % 2:
        return float(np.partition(values, k)[k])
    part = np.partition(values, (k - 1, k))
    return float(part[k - 1] + part[k]) / 2.0


def robust_sigma(values: np.ndarray) -> float:
    """Noise (DN) from horizontal neighbour differences: 1.4826 MAD / sqrt(2) (NaN-safe)."""
    d = np.diff(values, axis=1).ravel()
    if not np.isfinite(d).all():
        d = d[np.isfinite(d)]
    if d.size < 4:
        return 0.0
    return 1.4826 * median(np.abs(d - median(d))) / math.sqrt(2.0)


def ring_sides(v: np.ndarray, width: int) -> list[np.ndarray]:
    """The four sides of the outer ring (``width`` px) of ``v``, each flattened."""
    if v.shape[0] <= 2 * width or v.shape[1] <= 2 * width:
        return [v.ravel()]
    w = width
    return [v[:w].ravel(), v[-w:].ravel(), v[w:-w, :w].ravel(), v[w:-w, -w:].ravel()]


def side_levels(v: np.ndarray, width: int) -> list[float]:
    """Medians of the top, bottom, left and right sides of the outer ring (NaN: none finite)."""
    levels = []
    for side in ring_sides(v, width):
        if not np.isfinite(side).all():
            side = side[np.isfinite(side)]
        levels.append(median(side) if side.size else math.nan)
    return levels


def darkest_side_level(levels: list[float]) -> float:
    """The darkest side's median: the sky beside a treeline or cloud bank, not their mean."""
    finite = [v for v in levels if math.isfinite(v)]
    return min(finite) if finite else math.nan


def looks_level(levels: list[float], sigma: float) -> bool:
    """True when opposite sides differ by less than 2 sigma: no tilt worth a plane fit."""
    if len(levels) != 4 or not all(math.isfinite(v) for v in levels):
        return False
    top, bottom, left, right = levels
    return abs(bottom - top) < 2.0 * sigma and abs(right - left) < 2.0 * sigma
