"""Averages of a finely sampled spectrum over the model's spectral bins.

The model integrates over the band on Gauss-Legendre nodes (:func:`snrmon.model.radiometry.
band_nodes`). A transmission spectrum from a radiative-transfer code (MODTRAN tape7, the LOWTRAN7
table) is much finer than the nodes and full of lines; SAMPLING it at the nodes aliases its
structure into the band integral (+-2 %, up to 8 % on a MODTRAN spectrum), so each node gets the
AVERAGE of the spectrum over its own cell instead. With the quadrature weights given, the cells
are the intervals of the weights' cumulative sums from the band's lower edge (for Gauss-Legendre
they interlace with the nodes), so that sum(weights x cell averages) is exactly the integral of
the spectrum over the band; without them, the cells are bounded by the midpoints between nodes.
The spectrum between its samples is taken as linear (its samples' own interpolant), constant
beyond its ends.
"""

from __future__ import annotations

import numpy as np


def cell_edges(nodes: np.ndarray, weights: np.ndarray | None = None) -> np.ndarray:
    """The n + 1 edges of the n nodes' cells (module docstring); ascending nodes."""
    x = np.asarray(nodes, dtype=float)
    if x.ndim != 1 or x.size < 2 or np.any(np.diff(x) <= 0):
        raise ValueError("spectral nodes must be >= 2 ascending wavelengths")
    if weights is not None:
        w = np.asarray(weights, dtype=float)
        if w.shape != x.shape or np.any(w <= 0):
            raise ValueError("quadrature weights must be > 0, one per node")
        lo = 0.5 * (x[0] + x[-1]) - 0.5 * float(np.sum(w))  # a symmetric rule on [lo, hi]
        return lo + np.concatenate([[0.0], np.cumsum(w)])
    mid = 0.5 * (x[1:] + x[:-1])
    return np.concatenate([[x[0] - (mid[0] - x[0])], mid, [x[-1] + (x[-1] - mid[-1])]])


def _segment(h: float, u0: float, u1: float) -> tuple[float, float]:
    """Integral of the linear interpolant over [u0, u1] of a segment of length h: the
    coefficients of its left and right samples."""
    d2 = (u1 * u1 - u0 * u0) / (2.0 * h)
    return (u1 - u0) - d2, d2


def bin_average_matrix(x: np.ndarray, edges: np.ndarray) -> np.ndarray:
    """A (n_cells, n_x) with (A @ y)[i] the mean over [edges[i], edges[i+1]] of the piecewise
    linear interpolant of samples y at ascending x (constant beyond x's ends)."""
    x = np.asarray(x, dtype=float)
    e = np.asarray(edges, dtype=float)
    if x.ndim != 1 or x.size < 2 or np.any(np.diff(x) <= 0):
        raise ValueError("a spectrum's samples must be >= 2 ascending wavelengths")
    if np.any(np.diff(e) <= 0):
        raise ValueError("bin edges must increase")
    out = np.zeros((e.size - 1, x.size))
    for i in range(e.size - 1):
        a, b = e[i], e[i + 1]
        row = out[i]
        # beyond the ends: the end samples, held constant
        if a < x[0]:
            row[0] += min(b, x[0]) - a
        if b > x[-1]:
            row[-1] += b - max(a, x[-1])
        lo, hi = max(a, x[0]), min(b, x[-1])
        if hi > lo:
            k0 = int(np.clip(np.searchsorted(x, lo, side="right") - 1, 0, x.size - 2))
            k1 = int(np.clip(np.searchsorted(x, hi, side="left") - 1, 0, x.size - 2))
            for k in range(k0, k1 + 1):
                h = x[k + 1] - x[k]
                u0 = max(lo, x[k]) - x[k]
                u1 = min(hi, x[k + 1]) - x[k]
                if u1 > u0:
                    cl, cr = _segment(h, u0, u1)
                    row[k] += cl
                    row[k + 1] += cr
        row /= b - a
    return out


_CACHE: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
_CACHE_SIZE = 64


def cell_averaging(source, nodes, weights=None) -> tuple[np.ndarray, np.ndarray]:
    """(columns, A): the samples of ``source.wavelength_um`` that the nodes' cells touch and
    the (n_nodes, n_columns) averaging matrix on them, cached per ``source.grid_key`` (the
    identity of its wavelength grid) and nodes."""
    key_nodes = tuple(np.atleast_1d(np.asarray(nodes, dtype=float)).tolist())
    key_w = None if weights is None else tuple(np.asarray(weights, dtype=float).tolist())
    key = (source.grid_key, key_nodes, key_w)
    hit = _CACHE.get(key)
    if hit is not None:
        return hit
    edges = cell_edges(np.asarray(key_nodes), None if key_w is None else np.asarray(key_w))
    a = bin_average_matrix(source.wavelength_um, edges)
    cols = np.flatnonzero(np.any(a != 0.0, axis=0))
    sub = a[:, cols]
    cols.setflags(write=False)
    sub.setflags(write=False)
    if len(_CACHE) >= _CACHE_SIZE:
        _CACHE.clear()
    _CACHE[key] = (cols, sub)
    return cols, sub
