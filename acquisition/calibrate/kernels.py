"""Compiled per-frame work of the calibration (numba; :mod:`acquisition.measure.jit` says how
they stay bit-identical to the NumPy they replace).

- :func:`correct_box`: the two-point correction and the background reference of a box of a
  frame without bad pixels (:meth:`acquisition.calibrate.calibration.Calibration.correct`,
  then minus the reference offset): float32 steps, the calibration's Python-float means
  rounded to float32 first, as NumPy does for a float32 array.
- :func:`rim_radiance` and :func:`std_ddof`: the sky temperature's region
  (:class:`acquisition.calibrate.sky_temperature.SkyTemperature`): its good pixels' radiance in
  float64, their mean, and ``np.std`` of their temperatures (NumPy's pairwise sums). The
  radiance-to-temperature table lookup stays ``np.interp``.
"""

from __future__ import annotations

import math

import numpy as np

from acquisition.measure.jit import kernel, pairwise_sum64, std_ddof

__all__ = ["any_set", "correct_box", "rim_radiance", "std_ddof"]


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
