"""Compiled per-frame work of the calibration (numba; :mod:`snrmon.acquisition.measure.jit` says how
they stay bit-identical to the NumPy they replace).

- :func:`correct_box`: the two-point correction and the background reference of a box of a
  frame without bad pixels (:meth:`snrmon.acquisition.calibrate.calibration.Calibration.correct`,
  then minus the reference offset): float32 steps, the calibration's Python-float means
  rounded to float32 first, as NumPy does for a float32 array.
- :func:`rim_radiance` and :func:`std_ddof`: the sky temperature's region
  (:class:`snrmon.acquisition.calibrate.sky_temperature.SkyTemperature`): its good pixels' radiance
  in float64, their mean, and ``np.std`` of their temperatures (NumPy's pairwise sums). The
  radiance-to-temperature table lookup stays ``np.interp``.
"""

from __future__ import annotations

import math

import numpy as np

from snrmon.acquisition.measure.jit import kernel, pairwise_sum64, std_ddof

__all__ = ["any_set", "correct_box", "lazy_correct", "rim_radiance", "sky_sample", "std_ddof"]


@kernel
def any_set(mask, y0, y1, x0, x1):
    """True when ``mask[y0:y1, x0:x1]`` holds a nonzero value."""
    for y in range(y0, y1):
        for x in range(x0, x1):
            if mask[y, x] != 0:
                return True
    return False


@kernel
def correct_box(raw, y0, y1, x0, x1, offset, resp, mo, mr, ref, calibrate, reference, out):
    """``out[y0:y1, x0:x1]`` = the corrected pixels of ``raw`` there (module docstring);
    ``calibrate``/``reference`` say which of the two apply."""
    mo32 = np.float32(mo)
    mr32 = np.float32(mr)
    for y in range(y0, y1):
        for x in range(x0, x1):
            v = np.float32(raw[y, x])
            if calibrate:
                lq = np.float32(np.float32(v - offset[y, x]) / resp[y, x])
                v = np.float32(mo32 + np.float32(mr32 * lq))
            if reference:
                v = np.float32(v - ref[y, x])
            out[y, x] = v


@kernel
def lazy_correct(
    raw, ry0, ry1, rx0, rx1, state, done, offset, resp, ref, bad, mo, mr, cal, sub, out
):
    """FrameCorrector.ensure of a read of rows ry0:ry1, columns rx0:rx1 in one call: cut to
    the square, nothing when a box corrected this frame holds it, else the 8 px tiles it falls
    in corrected into ``out`` (:func:`correct_box`; ``cal``, ``sub``: calibrate, subtract the
    reference) and their box added to ``done``. ``state`` = (square y0, y1, x0, x1, tile,
    boxes done). Returns 0 (nothing to do), 1 when the tiles hold a bad pixel (nothing done:
    the caller corrects the whole square), 2 when it corrected the box now last in ``done``,
    3 when it corrected a box ``done`` had no room for."""
    sy0, sy1, sx0, sx1, t = state[0], state[1], state[2], state[3], state[4]
    y0, y1 = max(ry0, sy0), min(ry1, sy1)
    x0, x1 = max(rx0, sx0), min(rx1, sx1)
    if y0 >= y1 or x0 >= x1:
        return 0  # outside the square: never read (reach_px), left as it stands
    n = state[5]
    for i in range(n):
        if done[i, 0] <= y0 and y1 <= done[i, 1] and done[i, 2] <= x0 and x1 <= done[i, 3]:
            return 0
    y0, y1 = max(y0 // t * t, sy0), min(-(-y1 // t) * t, sy1)
    x0, x1 = max(x0 // t * t, sx0), min(-(-x1 // t) * t, sx1)
    if cal and any_set(bad, y0, y1, x0, x1):
        return 1
    correct_box(raw, y0, y1, x0, x1, offset, resp, mo, mr, ref, cal, sub, out)
    if n < done.shape[0]:  # (a full list only costs a correction again: the same values)
        done[n, 0], done[n, 1], done[n, 2], done[n, 3] = y0, y1, x0, x1
        state[5] = n + 1
        return 2
    return 3


@kernel
def rim_radiance(frame, offset, resp, bad, dy, dx, py, px):
    """(count, radiances, their mean) of the good pixels at (py + dy, px + dx); count -1 when
    a pixel leaves the frame (no sample), the mean NaN below two pixels."""
    h, w = offset.shape
    n = dy.size
    lq = np.empty(n)
    for i in range(n):
        r, c = py + dy[i], px + dx[i]
        if r < 0 or c < 0 or r >= h or c >= w:
            return -1, lq[:0], math.nan
    m = 0
    for i in range(n):
        r, c = py + dy[i], px + dx[i]
        if bad[r, c] == 0:
            lq[m] = (np.float64(frame[r, c]) - np.float64(offset[r, c])) / np.float64(resp[r, c])
            m += 1
    if m < 2:
        return m, lq[:m], math.nan
    return m, lq[:m], pairwise_sum64(lq, 0, m) / m


@kernel
def _temperature(x, table, t, j):
    """(``np.interp(x, table, t, left=nan, right=nan)``, the table index it used) of one value,
    the search starting from the index ``j`` of the last value (the pixels of a rim lie close
    together in the table); NumPy's arithmetic (compiled_base.c's arr_interp): its slope, its
    retry from the right end on NaN, the node's own value on a node."""
    n = table.size
    if not (table[0] <= x <= table[-1]):
        return math.nan, j
    if x == table[n - 1]:
        return t[n - 1], n - 1
    j = min(max(j, 0), n - 2)
    if not (table[j] <= x < table[j + 1]):  # bisect: table[j] <= x < table[j + 1]
        lo, hi = 0, n - 1
        while hi - lo > 1:
            mid = (lo + hi) // 2
            if table[mid] <= x:
                lo = mid
            else:
                hi = mid
        j = lo
    if table[j] == x:
        return t[j], j
    slope = (t[j + 1] - t[j]) / (table[j + 1] - table[j])
    out = slope * (x - table[j]) + t[j]
    if out != out:
        out = slope * (x - table[j + 1]) + t[j + 1]
        if out != out and t[j] == t[j + 1]:
            out = t[j]
    return out, j


@kernel
def sky_sample(frame, offset, resp, bad, dy, dx, py, px, table, t):
    """(count, mean radiance, its temperature, the std (ddof 1) of the pixels' temperatures)
    of the good pixels at (py + dy, px + dx); count below 2: no sample."""
    n, lq, mean = rim_radiance(frame, offset, resp, bad, dy, dx, py, px)
    if n < 2:
        return n, math.nan, math.nan, math.nan
    temps = np.empty(n)
    j = 0
    for i in range(n):
        temps[i], j = _temperature(lq[i], table, t, j)
    return n, mean, _temperature(mean, table, t, j)[0], std_ddof(temps, 1)
