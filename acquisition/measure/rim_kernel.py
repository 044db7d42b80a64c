"""Compiled backgrounds of the target-aware Eq. (4) (:mod:`snrmon.acquisition.measure.target_snr`).

- :func:`rim_excesses`: :func:`snrmon.acquisition.measure.target_snr.rim_excess` for every growth
  ``k`` of the wing profile in one pass over the pixels around the rim. A rim's mean is a
  difference of two float64 sums of pixels; the compiled sums are used only where they are
  provably exact (integer pixels, or float32 pixels whose magnitudes and last places fit 52
  bits: then no order of summation can change them), else the caller sums with NumPy.
- :func:`rim_stats`: :func:`snrmon.acquisition.measure.background.background_stats` of one
  rectangle's rim (N = 1): NumPy's pairwise sums of the same float64 products, in the same order;
  :func:`rim_background` adds the gradient's ``hypot``: numba's ``math.hypot`` is the C
  library's ``hypot``, which NumPy's ``np.hypot`` of float64 calls too (tested bit for bit;
  Python's own ``math.hypot`` is another algorithm and differs in the last bit).
- :func:`brightest`: :func:`snrmon.acquisition.track.search.brightest_in`'s argmax (NaN never, first
  in row-major order among equals).
"""

from __future__ import annotations

import math

import numpy as np

from snrmon.acquisition.measure.jit import kernel, pairwise_sum64, sum_is_exact, ulp32

INTEGER, FLOAT32, OTHER = 0, 1, 2  # pixel kinds for the exactness proof


def pixel_kind(dtype: np.dtype) -> int:
    if dtype.kind in "ui" and dtype.itemsize <= 4:
        return INTEGER
    return FLOAT32 if dtype == np.float32 else OTHER


@kernel
def _exact_unit(region, kind):
    """(largest |pixel|, smallest last place of a nonzero pixel) of ``region``; the unit is 0
    when the sums cannot be proven exact (float64 pixels, or non-finite ones)."""
    if kind == OTHER:
        return math.inf, 0.0
    biggest = 0.0
    smallest = math.inf  # the smallest nonzero magnitude has the smallest last place
    for i in range(region.shape[0]):
        for j in range(region.shape[1]):
            v = abs(np.float64(region[i, j]))
            if not v < math.inf:
                return math.inf, 0.0
            biggest = max(biggest, v)
            if v != 0.0:
                smallest = min(smallest, v)
    if kind == INTEGER or smallest == math.inf:
        return biggest, 1.0
    return biggest, ulp32(smallest)


@kernel
def _rim_mean(region, oy, ox, rows, cols, x0, y0, x1, y1):
    """(mean, count) of the one-pixel rim of a frame rectangle; count 0 when it leaves the
    image (target_snr._rim_mean's None). ``region`` holds frame rows oy.., columns ox...
    target_snr sums the rectangle and its inside and subtracts: with exact sums (the caller's
    proof) that is the rim's own sum, taken here side by side."""
    if x0 < 0 or y0 < 0 or x1 >= cols or y1 >= rows or x1 - x0 < 2 or y1 - y0 < 2:
        return math.nan, 0
    total = 0.0  # float64 throughout (numba's float() keeps a float32 a float32)
    for x in range(x0, x1 + 1):
        total += np.float64(region[y0 - oy, x - ox])
        total += np.float64(region[y1 - oy, x - ox])
    for y in range(y0 + 1, y1):
        total += np.float64(region[y - oy, x0 - ox])
        total += np.float64(region[y - oy, x1 - ox])
    n = (x1 - x0 + 1) * (y1 - y0 + 1) - (x1 - x0 - 1) * (y1 - y0 - 1)
    return total / n, n


@kernel
def rim_excesses(region, oy, ox, rows, cols, rect, sigma, most, kind):
    """(exact, excess per k = 0..most) of the rim of ``rect`` = (x0, y0, x1, y1) grown by k
    against the rim 2 px farther out, NaN where a rim leaves the image. ``region``: the
    frame's pixels in rows oy.., columns ox.. holding the largest rim (within the image)."""
    out = np.full(most + 1, np.nan)
    biggest, unit = _exact_unit(region, kind)
    h, w = region.shape
    if unit == 0.0 or not sum_is_exact(biggest * h * w, unit):
        return False, out
    x0, y0, x1, y1 = rect[0], rect[1], rect[2], rect[3]
    for k in range(most + 1):
        here, nh = _rim_mean(region, oy, ox, rows, cols, x0 - k, y0 - k, x1 + k, y1 + k)
        g = k + 2
        far, nf = _rim_mean(region, oy, ox, rows, cols, x0 - g, y0 - g, x1 + g, y1 + g)
        if nh == 0 or nf == 0 or not sigma > 0:
            break
        out[k] = (here - far) / (sigma * math.sqrt(1.0 / nh + 1.0 / nf))
    return True, out


@kernel
def wing_decision(recent, first, n, row, excess, z, min_frames):
    """WingProfile.growth's decision: this frame's ``excess`` goes into ``recent[row]`` step
    by step; the first k whose excess (alone, until ``min_frames`` are known) or whose mean
    over the recent frames (summed oldest first, as Python's ``sum``) is not significant.
    -1 when ``excess`` holds fewer steps than ``recent`` and none of them decided (the caller
    measures the rest and asks again: the same steps decide the same)."""
    frames, steps = recent.shape
    for k in range(excess.size):
        now = excess[k]
        recent[row, k] = now
        if not math.isfinite(now):
            return k
        total = 0.0
        m = 0
        for i in range(n):
            e = recent[(first + i) % frames, k]
            if math.isfinite(e):
                total += e
                m += 1
        if m < min_frames:
            if now <= z:
                return k
        elif total / m <= z / math.sqrt(m):
            return k
    return steps - 1 if excess.size == steps else -1


@kernel
def rim_stats(region, detrend, ddof):
    """(mean, std, gx, gy, n) of the rim of ``region`` (the rectangle's pixels), as
    background_stats computes them for one frame: values in row-major order as float64, the
    offsets from the rectangle's centre."""
    h, w = region.shape
    n = 2 * w + 2 * (h - 2)
    values = np.empty(n)
    dx = np.empty(n)
    dy = np.empty(n)
    k = 0
    for i in range(h):
        for j in range(w):
            if i == 0 or i == h - 1 or j == 0 or j == w - 1:
                values[k] = np.float64(region[i, j])
                dy[k] = i - (h - 1) / 2.0
                dx[k] = j - (w - 1) / 2.0
                k += 1
    mean = pairwise_sum64(values, 0, n) / n
    dev = np.empty(n)
    for i in range(n):
        dev[i] = values[i] - mean
    prod = np.empty(n)
    for i in range(n):
        prod[i] = dx[i] * dx[i]
    sxx = pairwise_sum64(prod, 0, n)
    for i in range(n):
        prod[i] = dy[i] * dy[i]
    syy = pairwise_sum64(prod, 0, n)
    gx = 0.0
    gy = 0.0
    if sxx > 0:
        for i in range(n):
            prod[i] = dev[i] * dx[i]
        gx = pairwise_sum64(prod, 0, n) / sxx
    if syy > 0:
        for i in range(n):
            prod[i] = dev[i] * dy[i]
        gy = pairwise_sum64(prod, 0, n) / syy
    if detrend:
        for i in range(n):
            dev[i] = (dev[i] - gx * dx[i]) - gy * dy[i]
    for i in range(n):
        prod[i] = dev[i] * dev[i]
    std = math.sqrt(pairwise_sum64(prod, 0, n) / (n - ddof))
    return mean, std, gx, gy, n


@kernel
def rim_background(region, detrend, ddof):
    """(mean, std, gradient, n) of the rim of ``region``: :func:`rim_stats` and the plane's
    gradient magnitude ``hypot(gx, gy)`` (as ``background_stats`` returns it)."""
    mean, std, gx, gy, n = rim_stats(region, detrend, ddof)
    return mean, std, math.hypot(gx, gy), n


@kernel
def brightest(win):
    """Index (row-major) of the brightest pixel of the non-empty ``win``, NaN never, first
    among equals; -1 when no pixel is finite."""
    h, w = win.shape
    best = -1
    top = win[0, 0]
    finite = False
    for i in range(h):
        for j in range(w):
            v = win[i, j]
            if v != v:
                continue
            if v - v == 0:
                finite = True
            if best < 0 or v > top:
                best, top = i * w + j, v
    return best if finite else -1
