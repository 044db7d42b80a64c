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
import math

import numpy as np
from scipy.special import gammaln, ndtr

from snrmon.model.footprint import phase_grid, pixel_patterns
from snrmon.model.psf import Psf

_STEP = 0.002  # sigma: the lattice E[max] rounds the means near the top to
_FAR_STEPS = 10  # 4 sigma or more below the top: rounded to 0.02 sigma
_X_STEPS = 125  # the integration step of E[max], 0.25 sigma, in lattice steps
_GATHER_CHUNK = 200_000  # ln Phi look-ups per array in E[max]
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


def _log_phi_table(lo: int, hi: int) -> tuple[np.ndarray, int]:
    """ln Phi(i x 0.002) for (at least) i = lo..hi, the lattice of :func:`expected_max`, and
    the first i it holds."""
    block = 4096  # whole blocks, so that the usual spans (-6.5 to 18.5 sigma) share one table
    first = (lo // block) * block
    return _log_phi_blocks(first, -(-(hi + 1) // block) * block), first


@functools.lru_cache(maxsize=8)
def _log_phi_blocks(first: int, stop: int) -> np.ndarray:
    t = np.log(np.maximum(ndtr(np.arange(first, stop) * _STEP), 1e-300))
    t.setflags(write=False)
    return t


def expected_max(means: np.ndarray) -> np.ndarray:
    """E[max_i (m_i + z_i)] for each row of ``means`` (..., n_pixels), z_i independent unit
    normals: the integral of the distribution of the maximum, F(x) = prod Phi(x - m_i), from
    5.5 sigma below the brightest mean to 6.5 sigma above max(top, 0) (the trapezoid rule
    converges fast on this smooth integrand: within 4e-9 sigma of a 0.01 step from 8 sigma
    below to 8 above, at a 0.25 step, on 1554 rows of the presets' patterns, faint to 1e5
    sigma)."""
    m = np.asarray(means, dtype=float)
    flat = m.reshape(-1, m.shape[-1])
    rows = len(flat)
    # Pixels 12 sigma below the top never matter (Phi(x - m) = 1 within 1e-9 where F > 0);
    # equal means (a symmetric pattern, the many noise-only pixels) enter once with a count,
    # rounded to 0.002 sigma near the top and 0.02 sigma 4 sigma below it (< 0.001 sigma).
    # On that lattice, with x on it too, ln Phi(x - m) is a look-up in one table.
    top = flat.max(axis=1)
    below = top[:, None] - flat
    near = below < 4.0
    used = near | (below < 12.0)
    q = np.where(near, np.round(flat / _STEP), np.round(flat / (_STEP * _FAR_STEPS)) * _FAR_STEPS)
    unused = np.iinfo(np.int64).min
    q = np.where(used, q, 0.0).astype(np.int64)
    q[~used] = unused
    q = np.sort(q, axis=1)[:, ::-1]  # brightest first, the unused last
    first = np.ones(q.shape, bool)
    first[:, 1:] = q[:, 1:] != q[:, :-1]
    group = np.cumsum(first, axis=1) - 1  # 0 for the top's value
    width = int(group[:, -1].max()) + 1
    slot = (np.arange(rows)[:, None] * width + group).ravel()
    counts = np.bincount(slot, minlength=rows * width).astype(float).reshape(rows, width)
    values = np.repeat(q[:, :1], width, axis=1)  # empty slots: the top, with no count
    r_i, c_i = np.nonzero(first)
    values[r_i, group[r_i, c_i]] = q[r_i, c_i]
    dead = values == unused
    counts[dead] = 0.0
    values[dead] = np.broadcast_to(q[:, :1], values.shape)[dead]
    groups = np.count_nonzero(counts, axis=1)
    lo = np.floor((top - _BELOW) / _STEP).astype(np.int64)
    span = (np.maximum(top, 0.0) + _ABOVE) / _STEP - lo
    nodes = np.ceil(span / _X_STEPS).astype(int) + 1  # x = lo + k 0.25 sigma; 49 for top >= 0
    start = lo[:, None] - values  # (x_0 - m) on the lattice
    out = np.empty(rows)
    # Rows of few distinct means (a bright peak: the rest is 12 sigma down) apart from rows of
    # many (a faint one), so that neither pays for the other's width; in chunks (small
    # arrays: 3x faster than one big (rows, nodes, means) array). Each row's sums have a length
    # set by the row alone (its width class, its nodes), so that a row reads the same in any
    # batch.
    widths = np.array([4, 16, 48, max(width, 48)])
    width_class = np.searchsorted(widths, groups)
    for key in np.unique(width_class * 100000 + nodes):
        part = np.nonzero(width_class * 100000 + nodes == key)[0]
        w, n_x = int(widths[key // 100000]), int(key % 100000)
        offset = np.zeros((part.size, w), np.int64)
        c = np.zeros((part.size, w))
        have = min(w, width)
        offset[:, :have] = start[part, :have]
        c[:, :have] = counts[part, :have]
        table, first_i = _log_phi_table(int(offset.min()), int(offset.max()) + _X_STEPS * n_x)
        offset -= first_i
        steps = _X_STEPS * np.arange(n_x)
        log_f = np.empty((part.size, n_x))
        chunk = max(1, _GATHER_CHUNK // (n_x * w))  # small arrays: memory-bound otherwise
        for i in range(0, part.size, chunk):
            idx = offset[i : i + chunk, None, :] + steps[None, :, None]
            log_f[i : i + chunk] = (table[idx] * c[i : i + chunk, None, :]).sum(axis=2)
        out[part] = np.trapezoid(1.0 - np.exp(log_f), dx=_X_STEPS * _STEP, axis=1)
    return (lo * _STEP + out).reshape(m.shape[:-1])


GUARD_PX = 2  # guard pixels between the target's extent and its background rim (target_snr)
EXTENT_SIGMA = 3.0  # a pixel belongs to the target's extent above 3 noise sigma
MAX_HALF_PX = 48  # the console analyses a target in at most 97 x 97 px (blob.py)


class PatternTooSmallError(ValueError):
    """The noise-free pattern does not hold the background rim the rule asks for."""


def _rect_rims(a: np.ndarray, x0, y0, x1, y1) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel count, mean and spread sum (a_j - mean)^2 of the one-pixel rim of the rectangle
    (x0, y0)-(x1, y1) (inclusive, one per pattern, at least 3 x 3) of each pattern ``a``
    (P, n, n)."""
    x0, y0, x1, y1 = (np.asarray(v, dtype=np.int64)[:, None] for v in (x0, y0, x1, y1))
    w, h = x1 - x0, y1 - y0  # the top and bottom edges: w + 1 pixels, the sides h - 1 more
    count = (2 * (w + h)).ravel()
    # walk the rim (top, right, bottom, left), always as far as the pattern's own edge: the
    # sums then do not depend on what else is in the batch
    t = np.arange(max(int(count.max()), 4 * (a.shape[-1] - 1)))[None, :]
    on_top, on_right, on_bottom = t < w, (t >= w) & (t < w + h), (t >= w + h) & (t < 2 * w + h)
    x = np.where(on_top, x0 + t, np.where(on_right, x1, np.where(on_bottom, x1 - (t - w - h), x0)))
    y = np.where(on_top, y0, np.where(on_right, y0 + (t - w), np.where(on_bottom, y1, 0)))
    y = np.where(on_top | on_right | on_bottom, y, y1 - (t - 2 * w - h))
    valid = t < count[:, None]
    n = a.shape[-1]
    values = a[np.arange(len(a))[:, None], np.clip(y, 0, n - 1), np.clip(x, 0, n - 1)]
    mean = np.where(valid, values, 0.0).sum(axis=1) / count
    spread = np.where(valid, (values - mean[:, None]) ** 2, 0.0).sum(axis=1)
    return count, mean, spread


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
    from scipy.ndimage import find_objects, label

    hb = box_px // 2
    n_pat, n = len(a), a.shape[-1]
    i = np.arange(n_pat)[:, None, None]
    d = np.arange(-hb, hb + 1)
    box = a[i, (r[:, None] + d)[:, :, None], (c[:, None] + d)[:, None, :]]
    p = extent_probabilities(box)
    x0, y0, x1, y1 = c - hb, r - hb, c + hb, r + hb
    lit = (p >= 1e-9) & (a[np.arange(n_pat), r, c] >= EXTENT_SIGMA)
    if np.any(lit):
        # each pattern's 8-connected extent at once: a structure that links no two patterns
        structure = np.zeros((3, 3, 3), bool)
        structure[1] = True
        which = np.nonzero(lit)[0]
        labels, _ = label(a[which] >= EXTENT_SIGMA, structure=structure)
        objects = find_objects(labels)
        for j, w in enumerate(which):
            ys, xs = objects[labels[j, r[w], c[w]] - 1][1:]
            x0[w], y0[w] = min(x0[w], xs.start), min(y0[w], ys.start)
            x1[w], y1[w] = max(x1[w], xs.stop - 1), max(y1[w], ys.stop - 1)
    g = GUARD_PX + 1
    rect = (x0 - g, y0 - g, x1 + g, y1 + g)
    outside = (rect[0] < 0) | (rect[1] < 0) | (rect[2] >= n) | (rect[3] >= n)
    return p, rect, outside & (p >= 1e-9)


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
    for background in backgrounds:
        if background not in ("rim", "target"):
            raise ValueError(f"background must be 'rim' or 'target', got {background!r}")
    a = np.asarray(a, dtype=float)
    lead = a.shape[:-2]
    n = a.shape[-1]
    pats = a.reshape(-1, n, n)
    c = n // 2
    hs, hb = search_px // 2, box_px // 2
    k = np.arange(n) - c
    dist = (k[:, None] ** 2 + k[None, :] ** 2).ravel()
    scale = 1.0 + np.abs(pats).reshape(len(pats), -1).max(axis=1)
    best = np.argmax(pats.reshape(len(pats), -1) - 1e-9 * scale[:, None] * dist[None, :], axis=1)
    r, col = np.divmod(best, n)
    reach = max(hs, hb)
    if np.any(np.abs(r - c) + reach > c) or np.any(np.abs(col - c) + reach > c):
        raise ValueError(f"pattern of {n} px is too small for the search window and the box")
    i = np.arange(len(pats))[:, None, None]
    ds = np.arange(-hs, hs + 1)
    search = pats[i, (r[:, None] + ds)[:, :, None], (col[:, None] + ds)[:, None, :]]
    peak = expected_max(search.reshape(len(pats), -1))
    d = np.arange(-hb, hb + 1)
    box = pats[i, (r[:, None] + d)[:, :, None], (col[:, None] + d)[:, None, :]]
    cells, _ = _rim_links(box_px)
    rim = box.reshape(len(pats), -1)[:, cells]
    mean = rim.mean(axis=1)
    spread = np.sum((rim - mean[:, None]) ** 2, axis=1)
    seven = (peak - mean) * _rim_std_factors(np.asarray(rim.shape[1]), ddof, spread)
    out = np.zeros((len(backgrounds), len(pats)))
    too_small = np.zeros(len(pats), bool)
    for b, background in enumerate(backgrounds):
        out[b] = seven
        if background == "rim":
            continue
        p, rect, too_small = target_backgrounds(pats, r, col, box_px)
        far = (p >= 1e-9) & ~too_small
        if np.any(far):
            x0, y0, x1, y1 = (v[far] for v in rect)
            count, mean, spread = _rect_rims(pats[far], x0, y0, x1, y1)
            extent = (peak[far] - mean) * _rim_std_factors(count, ddof, spread)
            out[b, far] = (1.0 - p[far]) * seven[far] + p[far] * extent
    return out.reshape((len(backgrounds), *lead)), too_small.reshape(lead)


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
        ph = phase_grid(phases)
        ph_x, ph_y, weights = ph, ph, np.full((len(ph), len(ph)), 1.0 / len(ph) ** 2)
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
    # the targets' patterns, each size computed once, in batches of one pattern size (sizes
    # rounded up to 4 px for fewer batches: a larger pattern reads the same)
    half = np.full(flat_amp.size, base_half)
    if "target" in backgrounds:  # room for the target, the guard and the rim around it
        room = np.ceil(flat_d / 2 + 3.0 * flat_s).astype(int)
        half += np.where(room > 1, -(-room // 4) * 4, room)
    pending = np.array(todo, dtype=int)
    while pending.size:
        retry = []
        for h in np.unique(half[pending]):
            batch = pending[half[pending] == h]
            pats, w = zip(
                *(
                    phase_patterns(
                        psf, fill_factor, float(flat_d[i]), float(flat_s[i]), int(h), phase_key
                    )
                    for i in batch
                ),
                strict=True,
            )
            a = flat_amp[batch][:, None, None, None] * np.stack(pats)
            readings, too_small = _readings(a, search_px, box_px, ddof, backgrounds)
            small = too_small.any(axis=1)
            for j, i in enumerate(batch):
                if small[j]:
                    if h >= MAX_HALF_PX:
                        raise PatternTooSmallError(
                            "pattern too small for the target's background rim"
                        )
                    half[i] = min(2 * h, MAX_HALF_PX)  # a bright target's 3-sigma extent is wide
                    retry.append(i)
                    continue
                out[:, i] = readings[:, j] @ w[j]
                if len(readings_kept) >= _READINGS_KEPT:
                    readings_kept.pop(next(iter(readings_kept)), None)  # the oldest
                readings_kept[keys[i]] = out[:, i].copy()
        pending = np.array(retry, dtype=int)
    return {rule: out[b].reshape(amp.shape) for b, rule in enumerate(backgrounds)}


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


@functools.lru_cache(maxsize=256)
def phase_patterns(
    psf: Psf,
    fill_factor: float,
    target_square_px: float,
    target_sigma_px: float,
    half_size_px: int,
    phase_key: tuple,
) -> tuple[np.ndarray, np.ndarray]:
    """The noise-free patterns (unit amplitude) of one target over the phases ``phase_key`` =
    (x phases, y phases, weights (n_y, n_x)) as tuples, and their weights: (P, n, n) and (P,),
    cached (the expected reading's cost at a new amplitude is then the estimator's alone).
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
    out.setflags(write=False)
    w.setflags(write=False)
    return out, w


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
