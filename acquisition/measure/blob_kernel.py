"""The compiled body of :func:`snrmon.acquisition.measure.blob.analyse_blob` (one window's
analysis).

:func:`window_stats` is the window's noise and levels (``robust_sigma``, ``side_levels`` and the
border ring's spread of :mod:`snrmon.acquisition.measure.local_sky`); :func:`analyse_window` the
climb, the saddle's bisection, the core, its centroid and the extent, each connected set found by
:func:`flood`: OpenCV's ``floodFill`` with ``FLOODFILL_FIXED_RANGE`` on a float32 window, 8-way,
whose test for a pixel ``v`` against the seed's ``v0`` is ``-lo <= v - v0 <= up`` in float32
with ``lo``, ``up`` the float32 roundings of the differences given (so exactly the pixels
OpenCV's fill takes, not ``v >= level``). The plane fit of a sloping sky stays in NumPy
(``flatten_sky``: its 3x3 solve is LAPACK's); the caller runs it when :func:`window_stats` says
the sides are not level, then analyses the flattened window.

Everything is float32 where the NumPy code was (the window, differences, weights) and float64
where it was Python floats; :mod:`snrmon.acquisition.measure.jit` says how sums and medians match.
"""

from __future__ import annotations

import math

import numpy as np

from snrmon.acquisition.measure.jit import (
    index_weighted_sum,
    kernel,
    median32,
    pairwise_sum32,
    pymax,
    pymin,
)

UP_DIFF = np.float32(1e30)  # blob.py's upper difference: any finite pixel above the level


@kernel
def _median_of(values, n, buf):
    """Median of the finite ``values[:n]`` (NaN when none), using ``buf`` as scratch."""
    m = 0
    for i in range(n):
        if math.isfinite(values[i]):
            buf[m] = values[i]
            m += 1
    if m == 0:
        return math.nan, 0
    return median32(buf, m), m


@kernel
def _mad_spread(values, n, buf, buf2):
    """(median of |values - median|, count) of the finite ``values[:n]`` (float32 steps).
    The deviations are taken in the values' own order, not the selection's (a half-sorted
    array is a quickselect's slow case)."""
    med, m = _median_of(values, n, buf)
    if m == 0:
        return 0.0, 0
    c = np.float32(med)
    j = 0
    for i in range(n):
        if math.isfinite(values[i]):
            buf2[j] = abs(np.float32(values[i] - c))
            j += 1
    return median32(buf2, m), m


@kernel
def window_stats(v, ring_px):
    """(finite, robust sigma, number of sides (1 or 4), their medians, ring spread) of the
    float32 window ``v`` (``_Window``'s: robust_sigma, side_levels, 1.4826 MAD of the ring).
    No sides (0) when a pixel is -0.0: which zero a median is then is np.partition's choice,
    so the caller takes NumPy's."""
    h, w = v.shape
    size = h * w
    buf = np.empty(size + 4, np.float32)
    buf2 = np.empty(size + 4, np.float32)
    vals = np.empty(size + 4, np.float32)
    finite = True
    signed_zero = False
    for i in range(h):
        for j in range(w):
            if not math.isfinite(v[i, j]):
                finite = False
            elif v[i, j] == 0 and math.copysign(1.0, v[i, j]) < 0:
                signed_zero = True
    if signed_zero:  # np.partition may take -0.0 or 0.0 as a median: NumPy's own (the caller)
        return finite, math.nan, 0, np.full(4, np.nan), math.nan
    # robust_sigma: horizontal neighbour differences, row-major.
    n = 0
    for i in range(h):
        for j in range(w - 1):
            vals[n] = np.float32(v[i, j + 1] - v[i, j])
            n += 1
    sigma = 0.0
    mad, m = _mad_spread(vals, n, buf, buf2)
    if m >= 4:
        sigma = 1.4826 * mad / math.sqrt(2.0)
    levels = np.full(4, np.nan)
    r = ring_px
    if h <= 2 * r or w <= 2 * r:
        sides = 1
        n = 0
        for i in range(h):
            for j in range(w):
                vals[n] = v[i, j]
                n += 1
        levels[0] = _median_of(vals, n, buf)[0]
        ring_n = n
    else:
        sides = 4
        for s in range(4):
            n = 0
            if s < 2:
                rows0 = 0 if s == 0 else h - r
                for i in range(rows0, rows0 + r):
                    for j in range(w):
                        vals[n] = v[i, j]
                        n += 1
            else:
                cols0 = 0 if s == 2 else w - r
                for i in range(r, h - r):
                    for j in range(cols0, cols0 + r):
                        vals[n] = v[i, j]
                        n += 1
            levels[s] = _median_of(vals, n, buf)[0]
        n = 0  # the ring, side after side (its order does not change a median)
        for i in range(h):
            for j in range(w):
                if i < r or i >= h - r or j < r or j >= w - r:
                    vals[n] = v[i, j]
                    n += 1
        ring_n = n
    mad, m = _mad_spread(vals, ring_n, buf, buf2)
    spread = 1.4826 * mad if m else 0.0
    return finite, sigma, sides, levels, spread


@kernel
def _spread(v, x, y, v0, lo, lab, stamp, stack, top):
    """One step of the fixed-range fill: (x, y)'s neighbours whose value minus the seed's ``v0``
    lies in [lo, UP_DIFF] join the set and the stack; returns the stack's new top."""
    h, w = v.shape
    for yy in range(max(y - 1, 0), min(y + 2, h)):
        for xx in range(max(x - 1, 0), min(x + 2, w)):
            if lab[yy, xx] != stamp:
                diff = np.float32(v[yy, xx] - v0)
                if lo <= diff and diff <= UP_DIFF:
                    lab[yy, xx] = stamp
                    stack[top] = yy * w + xx
                    top += 1
    return top


@kernel
def flood(v, sx, sy, level, lab, stamp, stack):
    """OpenCV's fixed-range fill from (sx, sy) at ``level`` (module docstring): marks
    ``lab == stamp``; returns (area, x0, y0, x1, y1, max value) of the set."""
    w = v.shape[1]
    v0 = v[sy, sx]
    d = np.float64(v0) - level
    lo = -np.float32(pymax(d, 0.0))
    lab[sy, sx] = stamp
    stack[0] = sy * w + sx
    top = 1
    area = 0
    x0, y0, x1, y1 = sx, sy, sx, sy
    vmax = v0
    while top > 0:
        top -= 1
        p = stack[top]
        y = p // w
        x = p - y * w
        area += 1
        x0 = min(x0, x)
        x1 = max(x1, x)
        y0 = min(y0, y)
        y1 = max(y1, y)
        if v[y, x] > vmax:
            vmax = v[y, x]
        top = _spread(v, x, y, v0, lo, lab, stamp, stack, top)
    return area, x0, y0, x1, y1, vmax


@kernel
def _near_border(geo, x0, y0, x1, y1, room):
    """blob._near_border: ``geo`` = (window x0, y0, x1, y1, frame rows, frame cols)."""
    wx0, wy0, wx1, wy1, rows, cols = geo[0], geo[1], geo[2], geo[3], geo[4], geo[5]
    return (
        (wx0 > 0 and x0 - wx0 < room)
        or (wy0 > 0 and y0 - wy0 < room)
        or (wx1 < cols - 1 and wx1 - x1 < room)
        or (wy1 < rows - 1 and wy1 - y1 < room)
    )


@kernel
def _is_open(v, sx, sy, level, peak, lab, stamp, stack):
    """blob._Window.is_open: the fill at ``level`` reaches the window's border or a pixel
    brighter than ``peak`` (the fill stops at the first such pixel)."""
    h, w = v.shape
    v0 = v[sy, sx]
    lo = -np.float32(pymax(np.float64(v0) - level, 0.0))
    lab[sy, sx] = stamp
    stack[0] = sy * w + sx
    top = 1
    while top > 0:
        top -= 1
        p = stack[top]
        y = p // w
        x = p - y * w
        if x == 0 or y == 0 or x == w - 1 or y == h - 1 or np.float64(v[y, x]) > peak:
            return True
        top = _spread(v, x, y, v0, lo, lab, stamp, stack, top)
    return False


@kernel
def _climb(v, sx, sy, k_climb, sigma, lab, stamp, stack):
    h, w = v.shape
    for _ in range(16):
        peak = np.float64(v[sy, sx])
        stamp += 1
        _, x0, y0, x1, y1, _ = flood(v, sx, sy, peak - k_climb * sigma, lab, stamp, stack)
        if x0 == 0 or y0 == 0 or x1 == w - 1 or y1 == h - 1:
            break
        tx, ty, top = sx, sy, v[sy, sx]
        first = True
        for y in range(y0, y1 + 1):  # the brightest of the set, first in row-major order
            for x in range(x0, x1 + 1):
                if lab[y, x] == stamp and (first or v[y, x] > top):
                    tx, ty, top, first = x, y, v[y, x], False
        t = np.float64(top)
        if not (t > peak or (t == peak and (ty < sy or (ty == sy and tx < sx)))):
            break
        sx, sy = tx, ty
    return sx, sy, stamp


@kernel
def _centroid(v, lab, stamp, cx0, cy0, cw, ch, saddle):
    """(ok, total, x, y) of the core's weighted centroid in window px, as blob.py sums it:
    float32 weights, their pairwise total, column sums row by row, row sums pairwise; the
    index-weighted sums are exact in float64 (checked; ``ok`` False when not provable)."""
    s32 = np.float32(saddle)
    wts = np.zeros(ch * cw, np.float32)
    for i in range(ch):
        for j in range(cw):
            if lab[cy0 + i, cx0 + j] == stamp:
                wts[i * cw + j] = np.float32(v[cy0 + i, cx0 + j] - s32)
    total = np.float64(pairwise_sum32(wts, 0, ch * cw))
    if not total > 0:
        return True, total, 0.0, 0.0
    col = np.zeros(cw, np.float32)
    if cw == 1:
        col[0] = pairwise_sum32(wts, 0, ch)
    else:
        for i in range(ch):
            for j in range(cw):
                col[j] = np.float32(col[j] + wts[i * cw + j])
    row = np.empty(ch, np.float32)
    for i in range(ch):
        row[i] = pairwise_sum32(wts, i * cw, cw)
    sx, x_exact = index_weighted_sum(col, cw)
    sy, y_exact = index_weighted_sum(row, ch)
    return x_exact and y_exact, total, sx / total, sy / total


@kernel
def analyse_window(v, geo, sx, sy, sigma, background, sky_sigma, integer, cfg):
    """blob._analyse on window ``v`` from window px (sx, sy). ``geo`` = (window x0, y0, x1,
    y1, frame rows, cols); ``cfg`` = (k_climb, k_ext, core_fraction, margin_px). Returns
    (status, sx, sy, values, boxes, labels): status 0 = seed not finite, 1 = the climb left the
    window's middle, 2 = a blob, 3 = a blob whose centroid the caller computes (the core is
    ``labels == boxes[10]``). Values: peak, background, saddle, core level, centroid x, y,
    extent level, grow, weights' total; boxes: core area and box (window px), extent area and
    box (frame px)."""
    k_climb, k_ext, core_fraction, margin = cfg[0], cfg[1], cfg[2], int(cfg[3])
    vals = np.zeros(9)
    boxes = np.zeros(11, np.int64)
    h, w = v.shape
    lab = np.zeros((h, w), np.int32)
    if not math.isfinite(v[sy, sx]):
        return 0, sx, sy, vals, boxes, lab
    stack = np.empty(h * w, np.int64)
    stamp = 0
    sx, sy, stamp = _climb(v, sx, sy, k_climb, sigma, lab, stamp, stack)
    x, y = geo[0] + sx, geo[1] + sy
    if _near_border(geo, x, y, x, y, 3):
        return 1, sx, sy, vals, boxes, lab
    peak = np.float64(v[sy, sx])
    bg = background if math.isfinite(background) else peak
    step = pymax(pymax(0.25 * sigma, (peak - bg) / 64.0), 1.0 if integer else 0.0)
    lo = pymin(bg, peak)
    probe = pymin(bg + k_ext * sigma, peak)
    if _is_open(v, sx, sy, peak, peak, lab, stamp + 1, stack):
        saddle = peak
    elif not _is_open(v, sx, sy, lo, peak, lab, stamp + 2, stack):
        saddle = lo
    else:
        hi = peak
        if _is_open(v, sx, sy, probe, peak, lab, stamp + 3, stack):
            lo = probe
        else:
            hi = probe
        stamp += 3
        while hi - lo > step:
            mid = (lo + hi) / 2.0
            if integer:
                mid = float(math.floor(mid))
                if mid <= lo:
                    break
            stamp += 1
            if _is_open(v, sx, sy, mid, peak, lab, stamp, stack):
                lo = mid
            else:
                hi = mid
        saddle = lo
    stamp += 4
    core_level = saddle + core_fraction * (peak - saddle)
    if integer:
        core_level = pymin(pymax(float(math.ceil(core_level)), saddle + 1.0), peak)
    core_area, cx0, cy0, cx1, cy1, _ = flood(v, sx, sy, core_level, lab, stamp, stack)
    ok, total, ccx, ccy = _centroid(v, lab, stamp, cx0, cy0, cx1 - cx0 + 1, cy1 - cy0 + 1, saddle)
    status = 2 if ok else 3
    core_stamp = stamp
    if total > 0:
        centroid_x = (geo[0] + cx0) + ccx
        centroid_y = (geo[1] + cy0) + ccy
    else:
        centroid_x, centroid_y = float(x), float(y)
    extent_level = pymin(pymax(bg, saddle) + k_ext * sky_sigma, core_level)
    stamp += 1
    ext_area, ex0, ey0, ex1, ey1, _ = flood(v, sx, sy, extent_level, lab, stamp, stack)
    ex0, ey0, ex1, ey1 = geo[0] + ex0, geo[1] + ey0, geo[0] + ex1, geo[1] + ey1
    grow = _near_border(geo, ex0, ey0, ex1, ey1, 2 + margin)
    if not grow and saddle - bg > 0.5 * (peak - bg) and saddle < peak:
        stamp += 1
        _, ax0, ay0, ax1, ay1, _ = flood(v, sx, sy, saddle, lab, stamp, stack)
        grow = _near_border(geo, geo[0] + ax0, geo[1] + ay0, geo[0] + ax1, geo[1] + ay1, 1)
    vals[0], vals[1], vals[2], vals[3] = peak, bg, saddle, core_level
    vals[4], vals[5], vals[6] = centroid_x, centroid_y, extent_level
    vals[7] = 1.0 if grow else 0.0
    vals[8] = total
    boxes[0], boxes[1], boxes[2], boxes[3], boxes[4] = core_area, cx0, cy0, cx1, cy1
    boxes[5], boxes[6], boxes[7], boxes[8], boxes[9] = ext_area, ex0, ey0, ex1, ey1
    boxes[10] = core_stamp
    return status, sx, sy, vals, boxes, lab


@kernel
def _looks_level(sides, levels, sigma):
    """local_sky.looks_level: four finite sides, opposite ones within 2 sigma."""
    if sides != 4:
        return False
    for i in range(4):
        if not math.isfinite(levels[i]):
            return False
    return abs(levels[1] - levels[0]) < 2.0 * sigma and abs(levels[3] - levels[2]) < 2.0 * sigma


@kernel
def _darkest(sides, levels):
    """local_sky.darkest_side_level: the first lowest finite side (NaN: none)."""
    out = math.nan
    for i in range(sides):
        if math.isfinite(levels[i]) and (out != out or levels[i] < out):
            out = levels[i]
    return out


@kernel
def analyse_auto(v, geo, sx, sy, given, has_given, floor, integer, flatten, ring_px, cfg):
    """blob._analyse's choice of the noise, background and sky sigma (window_stats), then
    :func:`analyse_window`; returns its values and the sigma. Two statuses more: 4, a -0.0
    pixel (the caller takes NumPy's medians); 5, the sides are not level and ``flatten`` is on
    (the caller fits the plane, then calls again with ``flatten`` off, the sigma given, and
    ``integer`` off if the plane changed the window)."""
    finite, estimate, sides, levels, spread = window_stats(v, ring_px)
    sig = pymax(given if has_given else estimate, floor)
    if sides == 0 or (flatten and finite and not _looks_level(sides, levels, sig)):
        h, w = v.shape
        empty = np.zeros((h, w), np.int32)
        return 4 if sides == 0 else 5, sx, sy, np.zeros(9), np.zeros(11, np.int64), empty, sig
    sky_sigma = pymax(sig, spread)
    status, sx, sy, vals, boxes, lab = analyse_window(
        v, geo, sx, sy, sig, _darkest(sides, levels), sky_sigma, integer, cfg
    )
    return status, sx, sy, vals, boxes, lab, sig
