"""What the paper's Eq. (4) estimator is expected to read, given the model's signal (section 5).

The model predicts the noise-free peak over the temporal noise, ``A x PVF`` (A: the target's
total contrast signal on the focal plane over the noise, PVF the phase-averaged share of the
brightest pixel). The measurement is not that number: per frame it takes the brightest pixel of
an 11 x 11 search window, subtracts the mean of the 24 rim pixels of the 7 x 7 box around it and
divides by their SAMPLE std, then averages the per-frame values over 100 frames. The expected
reading :func:`expected_eq4` is the mean over sub-pixel phases (uniform over the cell, the hover
drift) of

    (E[max_i (a_i + z_i)] - mean_rim(a)) x E[sigma / s_rim]

with a_i = A x (fraction of the energy on pixel i) in units of the noise sigma, z_i independent
unit normal noise, and the box centred on the brightest noise-free pixel. It contains:

* the **peak-search bias**: E[max] of the independent noisy pixels of the search window (the
  distribution of the maximum, F(x) = prod Phi(x - a_i), integrated exactly). On pure noise
  (A = 0) Eq. (4) reads 2.7 (E[max of 121 normals] = 2.58 times 1.034); with a point of SNR 3
  it reads ~12 % high, at SNR 5 ~4 %;
* the **rim share**: the PSF's and the target's light on the 24 rim pixels raises their mean
  (the numerator loses it) and their spread (the denominator gains the variance of the rim's
  signal, lambda = sum (a_j - mean)^2);
* the **24-pixel sample std**: E[sigma/s] of a chi distribution with 23 degrees of freedom is
  1.0342 for ``ddof=1`` (1.0564 for ddof=0); with rim signal the non-central chi-square is
  taken by Patnaik's two-moment approximation, c chi^2(nu) with c = (k + 2 lambda)/(k + lambda),
  nu = (k + lambda)^2 / (k + 2 lambda), k = 23, whose E[s^-1] is a ratio of gamma functions.

The console measures a target wider than Eq. (4)'s 5x5 guard against a background farther out
(``acquisition.measure.target_snr``): the one-pixel rim of the target's extent (its
pixels above 3 sigma) grown by a 2 px guard. ``background="target"`` (:func:`target_background`)
follows that rule on the noise-free pattern, so at close range the prediction is of what the
console reads (``"rim"``: the paper's fixed 7x7 estimator alone, which on a resolved drone reads
the drone against itself: MWIR 2.7 at 37 m and 19 at 126 m where the console reads hundreds).
The extent is decided per frame on noisy pixels, so the two backgrounds are weighted by the
probability that the extent reaches the 7x7 rim (:func:`target_backgrounds`). The console also
moves a compact target's rim out when the track's recent frames show PSF wings on it; that rule
is not modelled: on the twin's flights the reading expected with the PSF fitted to the flight's
frames agrees with the measurement (within 10 %) with the 7x7 rim and not with the rim moved
out (up to 30 % high at MWIR 393 m), which says the fitted PSF's wings, not the rule, are what
is still to be understood there (docs/model.md).

Not in it: the drone's own shot noise on its pixels (it widens the peak's noise, not its mean),
fixed-pattern residuals (the paper removes them), a box whose peak moved to a neighbour at low
SNR (the box is taken around the brightest noise-free pixel). The tests hold the formula to a
Monte Carlo of the real estimator (``acquisition.measure.peak_snr``) within 2 %.
"""

from __future__ import annotations

import functools
import itertools
import math
from typing import NamedTuple

import numpy as np
from scipy.special import gammaln, ndtr

from snrmon.model.footprint import phase_nodes, pixel_patterns
from snrmon.model.psf import Psf

_STEP = 0.002  # sigma: the lattice E[max] rounds the means near the top to
_FAR_STEPS = 10  # 4 sigma or more below the top: rounded to 0.02 sigma
_X_STEPS = 125  # the integration step of E[max], 0.25 sigma, in lattice steps
_BELOW = 5.5  # sigmas: F(top - 5.5) < 2e-8 (what lies below adds < 1e-8 sigma)
_ABOVE = 6.5  # sigmas: 1 - F(max(top, 0) + 6.5) < 121 Phi(-6.5) = 5e-9 (< 1e-9 sigma beyond)


def rim_std_factor(n_rim: int = 24, ddof: int = 1, rim_signal_var: float = 0.0) -> float:
    """E[sigma / s] of the sample std s of ``n_rim`` unit-noise pixels that carry signal of
    spread ``rim_signal_var`` = sum (a_j - mean a)^2 (Patnaik's approximation; exact at 0)."""
    if n_rim < 3 or ddof not in (0, 1):
        raise ValueError(f"need >= 3 rim pixels and ddof 0 or 1, got {n_rim}, {ddof}")
    return float(_rim_std_factors(np.asarray(n_rim), ddof, np.asarray(rim_signal_var, float)))


def _rim_std_factors(n_rim: np.ndarray, ddof: int, rim_signal_var: np.ndarray) -> np.ndarray:
    """:func:`rim_std_factor` over arrays of rim sizes and signal spreads."""
    k = n_rim - 1.0
    lam = np.maximum(rim_signal_var, 0.0)
    c = (k + 2.0 * lam) / (k + lam)
    nu = (k + lam) ** 2 / (k + 2.0 * lam)
    e_inv_chi = np.exp(gammaln((nu - 1.0) / 2.0) - gammaln(nu / 2.0)) / math.sqrt(2.0)
    return np.sqrt(n_rim - ddof) * e_inv_chi / np.sqrt(c)


_LATTICE_BLOCK = 4096  # the ln Phi table in whole blocks: the usual spans share one table
_PAIRS_CHUNK = 4096  # (row, mean) pairs per gather in E[max]: arrays that stay in cache


@functools.lru_cache(maxsize=8)
def _log_phi_blocks(first: int, stop: int) -> np.ndarray:
    t = np.log(np.maximum(ndtr(np.arange(first, stop) * _STEP), 1e-300))
    t.setflags(write=False)
    return t


@functools.lru_cache(maxsize=4)
def _log_phi_comb(first: int, stop: int, n_x: int) -> np.ndarray:
    """ln Phi((first + i + k x 125) x 0.002) in row i, column k < ``n_x``: the integrand's
    ``n_x`` nodes of one mean (x - m on the lattice, 0.25 sigma apart) in one contiguous row,
    for the lattice [first, stop) (whole blocks)."""
    table = _log_phi_blocks(first, stop)
    step = table.strides[0]
    rows = table.size - _X_STEPS * (n_x - 1)
    comb = np.lib.stride_tricks.as_strided(table, (rows, n_x), (step, _X_STEPS * step)).copy()
    comb.setflags(write=False)
    return comb


def expected_max(means: np.ndarray) -> np.ndarray:
    """E[max_i (m_i + z_i)] for each row of ``means`` (..., n_pixels), z_i independent unit
    normals: the integral of the distribution of the maximum, F(x) = prod Phi(x - m_i), from
    5.5 sigma below the brightest mean to 6.5 sigma above max(top, 0) (the trapezoid rule
    converges fast on this smooth integrand: within 4e-9 sigma of a 0.01 step from 8 sigma
    below to 8 above, at a 0.25 step, on 1554 rows of the presets' patterns, faint to 1e5
    sigma)."""
    m = np.asarray(means, dtype=float)
    flat = m.reshape(-1, m.shape[-1])
    rows, width = flat.shape
    # Pixels 12 sigma below the top never matter (Phi(x - m) = 1 within 1e-9 where F > 0);
    # equal means (a symmetric pattern, the many noise-only pixels) enter once with a count,
    # rounded to 0.002 sigma near the top and 0.02 sigma 4 sigma below it (< 0.001 sigma).
    # On that lattice, with x on it too, ln Phi(x - m) is a look-up in one table.
    top = flat.max(axis=1)
    below = top[:, None] - flat
    near = below < 4.0
    q = np.where(near, np.round(flat / _STEP), np.round(flat / (_STEP * _FAR_STEPS)) * _FAR_STEPS)
    q[~(near | (below < 12.0))] = -np.inf
    q = np.sort(q, axis=1)[:, ::-1].ravel()  # each row brightest first, the unused last
    # each row's distinct values (runs of equal values, a run never crossing a row) and counts
    new = np.empty(q.size, bool)
    new[0] = True
    np.not_equal(q[1:], q[:-1], out=new[1:])
    new[::width] = True
    starts = np.flatnonzero(new)
    counts = np.diff(np.append(starts, q.size)).astype(float)
    used = q[starts] > -np.inf
    starts, counts = starts[used], counts[used]
    row = starts // width
    lo = np.floor((top - _BELOW) / _STEP).astype(np.int64)
    span = (np.maximum(top, 0.0) + _ABOVE) / _STEP - lo
    nodes = np.ceil(span / _X_STEPS).astype(np.int64) + 1  # x = lo + k 0.25 sigma; 49 for top >= 0
    offset = lo[row] - q[starts].astype(np.int64)  # (x_0 - m) on the lattice
    out = np.empty(rows)
    # ln F at each node is the sum over a row's distinct means, in their order (brightest
    # first): a row's sums depend on the row alone, so it reads the same in any batch
    for n_x in np.unique(nodes).tolist():
        in_rows = np.flatnonzero(nodes == n_x)
        pick = np.isin(row, in_rows) if in_rows.size < rows else slice(None)
        off, cnt, pair_row = offset[pick], counts[pick], row[pick]
        first = (int(off.min()) // _LATTICE_BLOCK) * _LATTICE_BLOCK
        stop = int(off.max()) + _X_STEPS * (n_x - 1) + 1
        comb = _log_phi_comb(first, -(-stop // _LATTICE_BLOCK) * _LATTICE_BLOCK, n_x)
        off = off - first
        row_start = np.flatnonzero(np.r_[True, pair_row[1:] != pair_row[:-1]])
        bounds = np.r_[row_start, pair_row.size]
        cuts = np.unique(
            np.r_[np.searchsorted(bounds, np.arange(0, off.size, _PAIRS_CHUNK)), row_start.size]
        )
        log_f = np.empty((row_start.size, n_x))
        for a, b in itertools.pairwise(cuts.tolist()):
            p0, p1 = bounds[a], bounds[b]
            terms = comb[off[p0:p1]]
            terms *= cnt[p0:p1, None]
            log_f[a:b] = np.add.reduceat(terms, row_start[a:b] - p0, axis=0)
        out[in_rows] = np.trapezoid(1.0 - np.exp(log_f), dx=_X_STEPS * _STEP, axis=1)
    return (lo * _STEP + out).reshape(m.shape[:-1])


GUARD_PX = 2  # guard pixels between the target's extent and its background rim (target_snr)
EXTENT_SIGMA = 3.0  # a pixel belongs to the target's extent above 3 noise sigma
MAX_HALF_PX = 48  # the console analyses a target in at most 97 x 97 px (blob.py)


class PatternTooSmallError(ValueError):
    """The noise-free pattern does not hold the background rim the rule asks for."""


class _Patterns(NamedTuple):
    """Square patterns of any sizes one after another: pixel (y, x) of pattern p is
    ``pixels[start[p] + y n[p] + x]`` (one estimator pass reads patterns of every size)."""

    pixels: np.ndarray
    start: np.ndarray  # (P,)
    n: np.ndarray  # (P,) their sides

    @classmethod
    def stack(cls, a: np.ndarray) -> _Patterns:
        """The patterns ``a`` (P, n, n)."""
        n = a.shape[-1]
        return cls(
            np.ascontiguousarray(a).reshape(-1), np.arange(len(a)) * n * n, np.full(len(a), n)
        )

    def at(self, which, y, x) -> np.ndarray:
        """Pixels (``y``, ``x``) of the patterns ``which``, the indices broadcast together."""
        return self.pixels[self.start[which] + y * self.n[which] + x]

    def full(self, which: np.ndarray) -> np.ndarray:
        """The patterns ``which`` (all of one size) as (len(which), n, n)."""
        n = int(self.n[which[0]])
        return self.pixels[self.start[which][:, None] + np.arange(n * n)].reshape(-1, n, n)


def _rim_walk(x0, y0, x1, y1):
    """The pixels (x, y) (L, P) of the one-pixel rim of each rectangle (x0, y0)-(x1, y1)
    (inclusive, at least 3 x 3), walked top, right, bottom, left; the walk's first ``count``
    steps valid (the rest repeat the rim); and ``count`` (P,)."""
    x0, y0, x1, y1 = (np.asarray(v, dtype=np.int64)[None, :] for v in (x0, y0, x1, y1))
    w, h = x1 - x0, y1 - y0  # the top and bottom edges: w + 1 pixels, the sides h - 1 more
    count = (2 * (w + h)).ravel()
    t = np.arange(int(count.max()))[:, None]
    on_top, on_right, on_bottom = t < w, (t >= w) & (t < w + h), (t >= w + h) & (t < 2 * w + h)
    x = np.where(on_top, x0 + t, np.where(on_right, x1, np.where(on_bottom, x1 - (t - w - h), x0)))
    y = np.where(on_top, y0, np.where(on_right, y0 + (t - w), np.where(on_bottom, y1, 0)))
    y = np.where(on_top | on_right | on_bottom, y, y1 - (t - 2 * w - h))
    return x, y, t < count[None, :], count


@functools.lru_cache(maxsize=4)
def _square_rim(side: int) -> tuple[np.ndarray, np.ndarray]:
    """The rim of a ``side`` x ``side`` square as (dx, dy) from its top-left pixel, in the
    order :func:`_rim_walk` walks it."""
    x, y, _, _ = _rim_walk([0], [0], [side - 1], [side - 1])
    return x[:, 0], y[:, 0]


def _rim_stats(values: np.ndarray, valid: np.ndarray, count: np.ndarray):
    """Mean and spread sum (a_j - mean)^2 of the ``valid`` ``values`` (L, P) of each column,
    summed in the walk's order (axis 0: one value after another, so that the invalid zeros
    after a short rim leave its sums as they are, whatever else is in the batch)."""
    mean = np.where(valid, values, 0.0).sum(axis=0) / count
    dev = values - mean
    spread = np.where(valid, dev * dev, 0.0).sum(axis=0)
    return mean, spread


def _rect_rims(pats: _Patterns, amp: np.ndarray, which: np.ndarray, x0, y0, x1, y1):
    """Pixel count, mean and spread sum (a_j - mean)^2 of the one-pixel rim of the rectangle
    (x0, y0)-(x1, y1) (inclusive, one per pattern, at least 3 x 3, inside the pattern) of the
    patterns a = ``amp`` x pattern at ``which``."""
    x, y, valid, count = _rim_walk(x0, y0, x1, y1)
    last = pats.n[which] - 1
    values = amp[which] * pats.at(which, np.clip(y, 0, last), np.clip(x, 0, last))
    return (count, *_rim_stats(values, valid, count))


@functools.lru_cache(maxsize=4)
def _rim_links(box_px: int) -> tuple[np.ndarray, np.ndarray]:
    """The rim pixels of a box (flat indices) and, for each, the guard-ring pixels beside it
    (flat indices, padded by repeating the first)."""
    hb, n = box_px // 2, box_px
    cells, links = [], []
    for i in range(n):
        for j in range(n):
            if max(abs(i - hb), abs(j - hb)) != hb:
                continue
            ii = range(max(i - 1, 1), min(i + 2, n - 1))
            jj = range(max(j - 1, 1), min(j + 2, n - 1))
            cells.append(i * n + j)
            links.append([y * n + x for y in ii for x in jj])
    width = max(len(v) for v in links)
    padded = np.array([v + [v[0]] * (width - len(v)) for v in links])
    return np.array(cells), padded


def extent_probabilities(box: np.ndarray) -> np.ndarray:
    """Probability that the segmented extent reaches the rim of each noise-free box ``box``
    (P, b, b) around the peak (noise sigma units): some rim pixel is >= 3 sigma in its frame
    and so is a pixel of the guard ring beside it that links it to the target (noise
    independent per pixel; the guard ring's link to the peak taken as given, as it is for any
    target bright enough to matter)."""
    cells, links = _rim_links(box.shape[-1])
    flat = box.reshape(len(box), -1)
    above = ndtr(flat[:, cells] - EXTENT_SIGMA)  # P(a + z >= 3)
    # the guard-ring neighbour most likely lit: Phi is monotonic, so the brightest one
    link = ndtr(flat[:, links].max(axis=2) - EXTENT_SIGMA)
    return 1.0 - np.prod(1.0 - above * link, axis=1)


def target_backgrounds(a: np.ndarray, r, c, box_px: int = 7):
    """The backgrounds the console's target-aware Eq. (4) takes for the noise-free patterns
    ``a`` (P, n, n; noise sigma units) whose brightest pixels are rows ``r``, columns ``c``, and
    their probabilities (module docstring): the 7x7 rim while the extent (8-connected pixels
    >= 3 sigma in the frame) stays within the 5x5 guard, else the rim of the extent's box (at
    least the 7x7 box) grown by the guard. The extent is decided per frame on noisy pixels, so
    a target whose light on the 7x7 rim is near 3 sigma is measured one way or the other frame
    by frame: weighting the two by that probability keeps the expectation continuous in
    range. Returns (p, (x0, y0, x1, y1), too_small): the probability of the extent's rim,
    its rectangle and whether that rim leaves the pattern, per pattern."""
    pats = _Patterns.stack(np.asarray(a, dtype=float))
    one = np.ones(len(pats.n))
    r, c = np.asarray(r), np.asarray(c)
    return _target_backgrounds(pats, one, r, c, _box(pats, one, r, c, box_px))[:3]


def _box(pats: _Patterns, amp: np.ndarray, r, c, box_px: int) -> np.ndarray:
    """The ``box_px`` square around (``r``, ``c``) of each pattern ``amp`` x pattern."""
    d = np.arange(-(box_px // 2), box_px // 2 + 1)
    which = np.arange(len(pats.n))[:, None, None]
    y, x = r[:, None, None] + d[None, :, None], c[:, None, None] + d[None, None, :]
    return amp[:, None, None] * pats.at(which, y, x)


def _target_backgrounds(pats: _Patterns, amp: np.ndarray, r, c, box: np.ndarray, shapes=None):
    """:func:`target_backgrounds` of the patterns ``amp`` x ``pats``, given their boxes around
    the peaks (:func:`_box`), and whether each pattern's extent reached the box's rim (else
    the rectangle is the box grown by the guard). ``shapes``: a function that gives the
    :func:`extent_shapes` of the patterns at the indices it is given (or None)."""
    box_px = box.shape[-1]
    hb = box_px // 2
    n_pat, n = len(pats.n), pats.n
    p = extent_probabilities(box)
    x0, y0, x1, y1 = c - hb, r - hb, c + hb, r + hb
    lit = (p >= 1e-9) & (box[:, hb, hb] >= EXTENT_SIGMA)
    # an 8-connected extent that leaves the box crosses its rim: none of whose pixels are
    # >= 3 sigma keeps the extent inside the box (the rectangle is the box's own)
    cells, _ = _rim_links(box_px)
    lit &= box.reshape(n_pat, -1)[:, cells].max(axis=1) >= EXTENT_SIGMA
    which = np.flatnonzero(lit)
    if which.size and shapes is not None:
        # where every pixel >= 3 sigma joins the peak (extent_shapes), the extent's box is
        # that of the rows and columns that hold one
        row_max, col_max, joined = shapes(which)
        a = amp[which, None]
        whole = a[:, 0] * joined < EXTENT_SIGMA
        rows, cols = a * row_max >= EXTENT_SIGMA, a * col_max >= EXTENT_SIGMA
        _widen_to_extent((x0, y0, x1, y1), which[whole], rows[whole], cols[whole])
        which = which[~whole]
    for side in np.unique(n[which]).tolist():
        from scipy.ndimage import label

        # each pattern's 8-connected extent at once: a structure that links no two patterns
        structure = np.zeros((3, 3, 3), bool)
        structure[1] = True
        some = which[n[which] == side]
        labels, _ = label(
            amp[some, None, None] * pats.full(some) >= EXTENT_SIGMA, structure=structure
        )
        # the bounding box of the peak's own component (other components: Airy rings)
        extent = labels == labels[np.arange(some.size), r[some], c[some]][:, None, None]
        _widen_to_extent((x0, y0, x1, y1), some, extent.any(axis=2), extent.any(axis=1))
    g = GUARD_PX + 1
    rect = (x0 - g, y0 - g, x1 + g, y1 + g)
    outside = (rect[0] < 0) | (rect[1] < 0) | (rect[2] >= n) | (rect[3] >= n)
    return p, rect, outside & (p >= 1e-9), lit


def _widen_to_extent(box, which: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> None:
    """Grow the rectangles ``box`` (x0, y0, x1, y1) at ``which`` to hold the extents whose
    rows and columns are the True of ``rows``, ``cols`` (len(which), m; False past a
    pattern's own side)."""
    x0, y0, x1, y1 = box
    m = rows.shape[-1]
    x0[which] = np.minimum(x0[which], cols.argmax(axis=1))
    y0[which] = np.minimum(y0[which], rows.argmax(axis=1))
    x1[which] = np.maximum(x1[which], m - 1 - cols[:, ::-1].argmax(axis=1))
    y1[which] = np.maximum(y1[which], m - 1 - rows[:, ::-1].argmax(axis=1))


def extent_shapes(u: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """What the extent's box of each pattern ``u`` (P, n, n) needs at any amplitude: the
    maximum of each row and each column (P, n), and the brightest pixel that does not join
    the pattern's brightest by the step toward it (P,; -inf if none). Every pixel that is
    not brighter than its neighbour one step toward the brightest (diagonal, or along the
    row or column it shares with it) is linked to it through pixels at least as bright: at
    an amplitude where no pixel that is (A x ``joined`` < 3 sigma), every pixel >= 3 sigma
    belongs to the peak's 8-connected extent, and the extent's box is that of the rows and
    columns that hold one. (On the presets' Airy-based PSFs every pixel joins; a flat-topped
    pattern may not, and is then labelled.)"""
    n_pat, n = len(u), u.shape[-1]
    flat = u.reshape(n_pat, -1)
    my, mx = np.divmod(flat.argmax(axis=1), n)
    k = np.arange(n)
    ny = k[None, :] + np.sign(my[:, None] - k[None, :])  # the row one step toward it
    nx = k[None, :] + np.sign(mx[:, None] - k[None, :])
    toward = u[np.arange(n_pat)[:, None, None], ny[:, :, None], nx[:, None, :]]
    joined = np.where(toward < u, u, -np.inf).reshape(n_pat, -1).max(axis=1)
    return u.max(axis=2), u.max(axis=1), joined


def readings_of_patterns(
    a: np.ndarray,
    *,
    search_px: int = 11,
    box_px: int = 7,
    ddof: int = 1,
    background: str = "rim",
) -> np.ndarray:
    """Expected Eq. (4) readings of noise-free patterns ``a`` (..., n, n) in units of the noise
    sigma: the search window and the box centred on each pattern's brightest pixel (ties, as
    for a uniform target or no target, go to the pixel nearest the centre); ``background``
    "rim" (the 7x7 rim) or "target" (:func:`target_backgrounds`)."""
    readings, too_small = _readings(a, search_px, box_px, ddof, (background,))
    if np.any(too_small):
        raise PatternTooSmallError("pattern too small for the target's background rim")
    return readings[0]


def _readings(a, search_px: int, box_px: int, ddof: int, backgrounds: tuple[str, ...]):
    """:func:`readings_of_patterns` for several background rules at once (one peak search):
    shape (len(backgrounds), ...), and whether each pattern was too small for the target
    rule's background (its reading is then not valid), shape (...)."""
    _check_backgrounds(backgrounds)
    a = np.asarray(a, dtype=float)
    lead = a.shape[:-2]
    n = a.shape[-1]
    stacked = a.reshape(-1, n, n)
    pats = _Patterns.stack(stacked)
    one = np.ones(len(stacked))
    max_abs, candidates = _peak_candidates(stacked)
    r, col, search = _peaks(pats, one, max_abs, candidates, search_px, box_px)
    peak = expected_max(search)
    out, too_small = _readings_at_peaks(pats, one, r, col, peak, box_px, ddof, backgrounds)
    return out.reshape((len(backgrounds), *lead)), too_small.reshape(lead)


def _check_backgrounds(backgrounds: tuple[str, ...]) -> None:
    for background in backgrounds:
        if background not in ("rim", "target"):
            raise ValueError(f"background must be 'rim' or 'target', got {background!r}")


def _peak_candidates(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """max |u| of each pattern ``u`` (P, n, n) and the pixels (flat indices, ascending, padded
    by repeating the centre) that can be its brightest at any amplitude A >= 0: the centre and
    those brighter than it. The peak search (:func:`_peaks`) maximises A u_i - eps (1 + A
    max|u|) d_i (d_i the squared distance from the centre, eps 1e-9): a pixel no brighter
    than the centre has A u_i <= A u_c and a penalty > 0 (d_i >= 1), so it falls strictly
    below the centre, whatever the rounding."""
    n = u.shape[-1]
    flat = u.reshape(len(u), -1)
    centre = (n // 2) * n + n // 2
    max_abs = np.maximum(flat.max(axis=1), -flat.min(axis=1))
    # the patterns whose brightest pixel is not the centre (a target off the pixel's centre)
    off = np.flatnonzero(max_abs > flat[:, centre])
    brighter = flat[off] > flat[off, centre : centre + 1]
    brighter[:, centre] = True
    # each row's candidates in index order, then the centre again (a repeat never wins the
    # argmax over its first occurrence)
    row, index = np.nonzero(brighter)
    count = np.bincount(row, minlength=off.size)
    rank = np.arange(row.size) - np.repeat(np.cumsum(count) - count, count)
    candidates = np.full((len(u), max(1, int(count.max(initial=0)))), centre)
    candidates[off[row], rank] = index
    return max_abs, candidates


def _peaks(pats: _Patterns, amp, max_abs, candidates, search_px: int, box_px: int):
    """Each pattern's (``amp`` x pattern) brightest pixel, row and column (ties, as for a
    uniform target or no target, go to the pixel nearest the centre), and the search window
    around it (P, search_px^2); ``max_abs``, ``candidates``: :func:`_peak_candidates` of the
    patterns."""
    n = pats.n[:, None]
    c = n // 2
    hs, hb = search_px // 2, box_px // 2
    cy, cx = np.divmod(candidates, n)
    dist = (cy - c) ** 2 + (cx - c) ** 2
    scale = 1.0 + amp * max_abs
    values = amp[:, None] * pats.pixels[pats.start[:, None] + candidates]
    pick = np.argmax(values - 1e-9 * scale[:, None] * dist, axis=1)
    r, col = np.divmod(np.take_along_axis(candidates, pick[:, None], axis=1)[:, 0], pats.n)
    c, reach = pats.n // 2, max(hs, hb)
    if np.any(np.abs(r - c) + reach > c) or np.any(np.abs(col - c) + reach > c):
        raise ValueError(f"pattern of {n.min()} px is too small for the search window and the box")
    ds = np.arange(-hs, hs + 1)
    which = np.arange(len(r))[:, None, None]
    search = pats.at(which, r[:, None, None] + ds[None, :, None], col[:, None, None] + ds)
    return r, col, amp[:, None] * search.reshape(len(r), -1)


def _readings_at_peaks(
    pats: _Patterns, amp, r, col, peak, box_px: int, ddof: int, backgrounds, shapes=None
):
    """The readings (len(backgrounds), P) of patterns ``amp`` x ``pats`` whose brightest
    pixels are ``r``, ``col`` and whose search windows' E[max] is ``peak``, and whether each
    was too small for the target rule's background (P,); ``shapes`` as in
    :func:`_target_backgrounds`."""
    box = _box(pats, amp, r, col, box_px)
    cells, _ = _rim_links(box_px)
    rim = box.reshape(len(r), -1)[:, cells]
    mean = rim.mean(axis=1)
    spread = np.sum((rim - mean[:, None]) ** 2, axis=1)
    seven = (peak - mean) * _rim_std_factors(np.asarray(rim.shape[1]), ddof, spread)
    out = np.zeros((len(backgrounds), len(r)))
    too_small = np.zeros(len(r), bool)
    for b, background in enumerate(backgrounds):
        out[b] = seven
        if background == "rim":
            continue
        p, rect, too_small, wide = _target_backgrounds(pats, amp, r, col, box, shapes)
        far = (p >= 1e-9) & ~too_small
        # the box grown by the guard: its rim at the same place around every peak
        grown = np.flatnonzero(far & ~wide)
        wide = np.flatnonzero(far & wide)
        x0, y0, x1, y1 = rect
        dx, dy = _square_rim(box_px + 2 * (GUARD_PX + 1))
        values = amp[grown] * pats.at(grown, y0[grown] + dy[:, None], x0[grown] + dx[:, None])
        count = np.full(grown.size, dx.size)
        stats = [(grown, count, *_rim_stats(values, np.ones(values.shape, bool), count))]
        if wide.size:
            rims = _rect_rims(pats, amp, wide, x0[wide], y0[wide], x1[wide], y1[wide])
            stats.append((wide, *rims))
        for at, count, mean, spread in stats:
            extent = (peak[at] - mean) * _rim_std_factors(count, ddof, spread)
            out[b, at] = (1.0 - p[at]) * seven[at] + p[at] * extent
    return out, too_small


def expected_eq4(
    psf: Psf,
    fill_factor: float,
    amplitude,
    *,
    target_square_px=0.0,
    target_sigma_px=0.0,
    search_px: int = 11,
    box_px: int = 7,
    ddof: int = 1,
    phases: int = 5,
    background: str = "rim",
    phases_xy=None,
) -> np.ndarray:
    """Expected mean Eq. (4) reading (see the module docstring) for total signals
    ``amplitude`` = contrast electrons on the focal plane / temporal noise (the SNR at PVF = 1),
    with the target a square of side ``target_square_px`` (or a Gaussian of
    ``target_sigma_px``) convolved with ``psf``. ``amplitude`` and the target sizes broadcast;
    ``phases`` x ``phases`` phases over the half cell (the symmetric quarter of the cell);
    ``background`` as in :func:`readings_of_patterns` ("target": what the console reads).

    ``phases_xy`` (N, 2): instead of phases uniform over the cell, the target centroid's offsets
    (x, y) from a pixel centre that N frames actually had (:func:`observed_phases`): the mean is
    over those frames. 100 frames of a hover do not sample the cell evenly; over the phases
    they sampled, the expectation is of what those frames read."""
    return expected_eq4_by_rule(
        psf,
        fill_factor,
        amplitude,
        target_square_px=target_square_px,
        target_sigma_px=target_sigma_px,
        search_px=search_px,
        box_px=box_px,
        ddof=ddof,
        phases=phases,
        backgrounds=(background,),
        phases_xy=phases_xy,
    )[background]


def expected_eq4_by_rule(
    psf: Psf,
    fill_factor: float,
    amplitude,
    *,
    target_square_px=0.0,
    target_sigma_px=0.0,
    search_px: int = 11,
    box_px: int = 7,
    ddof: int = 1,
    phases: int = 5,
    backgrounds: tuple[str, ...] = ("rim", "target"),
    phases_xy=None,
) -> dict[str, np.ndarray]:
    """:func:`expected_eq4` for several background rules at once, ``{rule: readings}``: the
    patterns and the peak search are the same for every rule, so they are computed once."""
    amp, d, s = np.broadcast_arrays(
        np.asarray(amplitude, float),
        np.asarray(target_square_px, float),
        np.asarray(target_sigma_px, float),
    )
    if np.any(~np.isfinite(amp)) or np.any(amp < 0):
        raise ValueError(f"signal amplitude must be >= 0, got {amplitude!r}")
    base_half = search_px // 2 + box_px // 2 + 1
    if phases_xy is None:
        ph, w = phase_nodes(psf, fill_factor, phases)
        ph_x, ph_y, weights = ph, ph, np.outer(w, w)
    else:
        ph_x, ph_y, weights = observed_phase_weights(phases_xy)
    phase_key = (tuple(ph_x.tolist()), tuple(ph_y.tolist()), tuple(map(tuple, weights.tolist())))
    flat_amp, flat_d, flat_s = amp.ravel(), d.ravel(), s.ravel()
    out = np.empty((len(backgrounds), flat_amp.size))
    readings_kept = _kept(
        (psf, float(fill_factor), phase_key, search_px, box_px, ddof, backgrounds)
    )
    keys = [
        (float(x), float(y), float(z)) for x, y, z in zip(flat_d, flat_s, flat_amp, strict=True)
    ]
    todo = []
    for i, key in enumerate(keys):
        known = readings_kept.get(key)
        if known is None:
            todo.append(i)
        else:
            out[:, i] = known
    # the targets' patterns, their sizes rounded up to 4 px (fewer sizes; a larger pattern
    # reads the same)
    half = np.full(flat_amp.size, base_half)
    if "target" in backgrounds:  # room for the target, the guard and the rim around it
        room = np.ceil(flat_d / 2 + 3.0 * flat_s).astype(int)
        half += np.where(room > 1, -(-room // 4) * 4, room)
    pending = np.array(todo, dtype=int)
    _check_backgrounds(backgrounds)
    while pending.size:
        # every target's patterns in one pass of the estimator, whatever their sizes
        kept = [
            phase_patterns(
                psf, fill_factor, float(flat_d[i]), float(flat_s[i]), int(half[i]), phase_key
            )
            for i in pending.tolist()
        ]
        readings, small = _pass_readings(
            kept, flat_amp[pending], search_px, box_px, ddof, backgrounds
        )
        retry = []
        for j, i in enumerate(pending.tolist()):
            if small[j]:
                if half[i] >= MAX_HALF_PX:
                    raise PatternTooSmallError("pattern too small for the target's background rim")
                half[i] = min(2 * half[i], MAX_HALF_PX)  # a bright target's 3-sigma extent is wide
                retry.append(i)
                continue
            out[:, i] = readings[:, j] @ kept[j].weights
            if len(readings_kept) >= _READINGS_KEPT:
                readings_kept.pop(next(iter(readings_kept)), None)  # the oldest
            readings_kept[keys[i]] = out[:, i].copy()
        pending = np.array(retry, dtype=int)
    return {rule: out[b].reshape(amp.shape) for b, rule in enumerate(backgrounds)}


def _pass_readings(
    kept: list, amplitude: np.ndarray, search_px: int, box_px: int, ddof: int, backgrounds
) -> tuple[np.ndarray, np.ndarray]:
    """One pass of the estimator over the targets of ``kept`` (their :func:`phase_patterns`)
    at their ``amplitude``: the readings (n_rules, n_targets, n_phases) and, per target,
    whether a pattern was too small for its background rule."""
    per = len(kept[0].weights)
    n = np.repeat([k.patterns.shape[-1] for k in kept], per)
    pats = _Patterns(
        np.concatenate([k.patterns.reshape(-1) for k in kept]),
        np.concatenate([[0], np.cumsum(n * n)[:-1]]),
        n,
    )
    a = np.repeat(amplitude, per)
    width = max(k.candidates.shape[1] for k in kept)
    candidates = np.concatenate([_widened(k.candidates, width) for k in kept])
    max_abs = np.concatenate([k.max_abs for k in kept])
    r, col, search = _peaks(pats, a, max_abs, candidates, search_px, box_px)
    readings, too_small = _readings_at_peaks(
        pats, a, r, col, expected_max(search), box_px, ddof, backgrounds, _shapes_of(kept)
    )
    readings = readings.reshape(len(backgrounds), len(kept), per)
    return readings, too_small.reshape(len(kept), per).any(axis=1)


_READINGS: dict[tuple, dict] = {}
_READINGS_KEPT = 5000  # per PSF: its readings over a few range grids and ~100 skies


def _kept(setting: tuple) -> dict:
    """The readings kept for ``setting`` (PSF, fill factor, phases, estimator) by (target size,
    Gaussian sigma, amplitude): the same inputs read the same again (a reading does not depend
    on what else was computed with it)."""
    kept = _READINGS.get(setting)
    if kept is None:
        if len(_READINGS) >= 16:
            _READINGS.pop(next(iter(_READINGS)), None)  # the oldest
        kept = _READINGS[setting] = {}
    return kept


class PhasePatterns(NamedTuple):
    """One target's noise-free patterns over the phases (:func:`phase_patterns`)."""

    patterns: np.ndarray  # (P, n, n), unit amplitude
    weights: np.ndarray  # (P,)
    max_abs: np.ndarray  # (P,) max |pattern|, and the pixels that can be the peak
    candidates: np.ndarray  # (P, K) (:func:`_peak_candidates`)
    shapes: dict  # extent_shapes, made the first time the target rule asks (_shapes_of)


def _shapes_of(kept: list[PhasePatterns]):
    """The ``shapes`` function (:func:`_target_backgrounds`) of the patterns of ``kept``
    stacked in order: :func:`extent_shapes` of each target's patterns, made once."""
    per = len(kept[0].weights)

    def shapes(which: np.ndarray):
        target, row = np.divmod(which, per)
        need = np.unique(target).tolist()
        for t in need:
            if "extent" not in kept[t].shapes:
                new = extent_shapes(kept[t].patterns)
                for v in new:
                    v.setflags(write=False)
                kept[t].shapes["extent"] = new
        made = [kept[t].shapes["extent"] for t in need]
        # rows and columns past a pattern's own side: -inf, never >= 3 sigma
        side = max(m[0].shape[1] for m in made)
        lines = np.full((2, len(need) * per, side), -np.inf)
        for j, m in enumerate(made):
            lines[0, j * per : (j + 1) * per, : m[0].shape[1]] = m[0]
            lines[1, j * per : (j + 1) * per, : m[1].shape[1]] = m[1]
        at = np.searchsorted(need, target) * per + row
        return lines[0, at], lines[1, at], np.concatenate([m[2] for m in made])[at]

    return shapes


def _widened(candidates: np.ndarray, width: int) -> np.ndarray:
    """Peak candidates padded to ``width`` columns by repeating their last (the centre)."""
    extra = width - candidates.shape[1]
    return candidates if extra == 0 else np.pad(candidates, ((0, 0), (0, extra)), mode="edge")


@functools.lru_cache(maxsize=256)
def phase_patterns(
    psf: Psf,
    fill_factor: float,
    target_square_px: float,
    target_sigma_px: float,
    half_size_px: int,
    phase_key: tuple,
) -> PhasePatterns:
    """The noise-free patterns (unit amplitude) of one target over the phases ``phase_key`` =
    (x phases, y phases, weights (n_y, n_x)) as tuples, their weights and the pixels that can
    be their peaks: (P, n, n), (P,), and :func:`_peak_candidates`, cached (the expected
    reading's cost at a new amplitude is then the estimator's alone, on the pixels it reads).
    Phases of no weight are left out; on a grid symmetric in x and y (the uniform cell) a
    pattern and its transpose read alike (the PSF and the target are symmetric), so each pair
    enters once with both weights."""
    ph_x, ph_y = np.asarray(phase_key[0]), np.asarray(phase_key[1])
    weights = np.asarray(phase_key[2], dtype=float)
    pats = pixel_patterns(
        psf,
        fill_factor,
        ph_x,
        ph_y,
        half_size_px=half_size_px,
        target_square_px=target_square_px,
        target_sigma_px=target_sigma_px,
    )
    if (
        ph_x.shape == ph_y.shape
        and np.array_equal(ph_x, ph_y)
        and np.array_equal(weights, weights.T)
    ):
        weights = np.triu(weights + weights.T) - np.diag(np.diag(weights))
    keep = weights > 0
    out, w = np.ascontiguousarray(pats[keep]), weights[keep]
    max_abs, candidates = _peak_candidates(out)
    for v in (out, w, max_abs, candidates):
        v.setflags(write=False)
    return PhasePatterns(out, w, max_abs, candidates, {})


PHASE_STEP_PX = 1.0 / 24.0  # observed phases are binned to this (the reading changes < 0.5 %)


def observed_phase_weights(phases_xy) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(x phases, y phases, weights (n_y, n_x)) of observed centroid offsets ``phases_xy``
    (N, 2) from a pixel centre: each folded into the half cell [0, 0.5] (the PSF and target
    are symmetric, and an offset past half a pixel is nearer the next pixel), binned to
    :data:`PHASE_STEP_PX`, weighted by how many frames fell in each bin."""
    p = np.asarray(phases_xy, dtype=float).reshape(-1, 2)
    if len(p) == 0 or not np.all(np.isfinite(p)):
        raise ValueError(f"observed phases must be finite (N, 2) offsets, got {len(p)} rows")
    folded = np.abs((p + 0.5) % 1.0 - 0.5)
    bins = np.rint(folded / PHASE_STEP_PX).astype(int)
    xs, ix = np.unique(bins[:, 0], return_inverse=True)
    ys, iy = np.unique(bins[:, 1], return_inverse=True)
    weights = np.zeros((len(ys), len(xs)))
    np.add.at(weights, (iy.ravel(), ix.ravel()), 1.0 / len(p))
    return xs * PHASE_STEP_PX, ys * PHASE_STEP_PX, weights
