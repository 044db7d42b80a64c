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

import math

import numpy as np
from scipy.special import gammaln, ndtr

from snrmon.model.footprint import phase_grid, pixel_patterns
from snrmon.model.psf import Psf

_X_STEP = 0.1  # integration step of E[max] in noise sigmas (trapezoid: < 1e-5 sigma error)
_TAIL = 6.5  # sigmas: F(top - 6.5) < 1e-10, and 1 - F(max(top, 0) + 6.5) < 1e-8


def rim_std_factor(n_rim: int = 24, ddof: int = 1, rim_signal_var: float = 0.0) -> float:
    """E[sigma / s] of the sample std s of ``n_rim`` unit-noise pixels that carry signal of
    spread ``rim_signal_var`` = sum (a_j - mean a)^2 (Patnaik's approximation; exact at 0)."""
    if n_rim < 3 or ddof not in (0, 1):
        raise ValueError(f"need >= 3 rim pixels and ddof 0 or 1, got {n_rim}, {ddof}")
    k = n_rim - 1.0
    lam = max(float(rim_signal_var), 0.0)
    c = (k + 2.0 * lam) / (k + lam)
    nu = (k + lam) ** 2 / (k + 2.0 * lam)
    e_inv_chi = math.exp(gammaln((nu - 1.0) / 2.0) - gammaln(nu / 2.0)) / math.sqrt(2.0)
    return math.sqrt(n_rim - ddof) * e_inv_chi / math.sqrt(c)


def expected_max(means: np.ndarray) -> np.ndarray:
    """E[max_i (m_i + z_i)] for each row of ``means`` (..., n_pixels), z_i independent unit
    normals: the integral of the distribution of the maximum, F(x) = prod Phi(x - m_i), from 7
    sigma below the brightest mean (F < 1e-12 there) to 7 sigma above max(top, 0) (the
    trapezoid rule converges fast on this smooth integrand: < 1e-5 sigma at a 0.1 step)."""
    m = np.asarray(means, dtype=float)
    flat = m.reshape(-1, m.shape[-1])
    # Pixels 12 sigma below the top never matter (Phi(x - m) = 1 within 1e-9 where F > 0);
    # equal means (a symmetric pattern, the many noise-only pixels) enter once with a count,
    # grouped to 0.002 sigma near the top and 0.02 sigma 4 sigma below it (< 0.001 sigma).
    groups = []
    for row in flat:
        t = row.max()
        near = row[row > t - 4.0]
        far = row[(row <= t - 4.0) & (row > t - 12.0)]
        v1, c1 = np.unique(np.round(near / 0.002) * 0.002, return_counts=True)
        v2, c2 = np.unique(np.round(far / 0.02) * 0.02, return_counts=True)
        groups.append((np.concatenate([v1, v2]), np.concatenate([c1, c2])))
    width = max(len(v) for v, _ in groups)
    values = np.zeros((len(flat), width))
    counts = np.zeros((len(flat), width))
    for i, (v, c) in enumerate(groups):
        values[i, : len(v)] = v
        values[i, len(v) :] = v[0]
        counts[i, : len(v)] = c
    top = flat.max(axis=1)
    lo = top - _TAIL
    span = np.maximum(top, 0.0) + _TAIL - lo
    k = np.arange(int(np.ceil(float(span.max()) / _X_STEP)) + 1)
    x = lo[:, None] + _X_STEP * k[None, :]  # (rows, nodes)
    log_phi = np.log(np.maximum(ndtr(x[:, :, None] - values[:, None, :]), 1e-300))
    f = np.exp(np.einsum("rkp,rp->rk", log_phi, counts))
    # beyond a row's own upper end 1 - F is < 1e-12: integrating the common grid is exact
    out = lo + np.trapezoid(1.0 - f, dx=_X_STEP, axis=1)
    return out.reshape(m.shape[:-1])


GUARD_PX = 2  # guard pixels between the target's extent and its background rim (target_snr)
EXTENT_SIGMA = 3.0  # a pixel belongs to the target's extent above 3 noise sigma
MAX_HALF_PX = 48  # the console analyses a target in at most 97 x 97 px (blob.py)


class PatternTooSmallError(ValueError):
    """The noise-free pattern does not hold the background rim the rule asks for."""


def _rect_rim(a: np.ndarray, rect: tuple[int, int, int, int]) -> np.ndarray | None:
    """The one-pixel rim of ``rect`` = (x0, y0, x1, y1) (inclusive) of pattern ``a``; None
    when it leaves the pattern."""
    x0, y0, x1, y1 = rect
    n_rows, n_cols = a.shape
    if x0 < 0 or y0 < 0 or x1 >= n_cols or y1 >= n_rows:
        return None
    box = a[y0 : y1 + 1, x0 : x1 + 1]
    return np.concatenate([box[0], box[-1], box[1:-1, 0], box[1:-1, -1]])


def _extent_probability(a: np.ndarray, r: int, c: int, hb: int) -> float:
    """Probability that the segmented extent reaches the 7x7 rim (Chebyshev distance ``hb``
    from the peak): some rim pixel is >= 3 sigma in its frame and so is a pixel of the guard
    ring beside it that links it to the target (noise independent per pixel; the guard ring's
    link to the peak taken as given, as it is for any target bright enough to matter)."""
    above = ndtr(a - EXTENT_SIGMA)  # P(a + z >= 3)
    box = above[r - hb : r + hb + 1, c - hb : c + hb + 1]
    n = 2 * hb + 1
    p_none = 1.0
    for i in range(n):
        for j in range(n):
            if max(abs(i - hb), abs(j - hb)) != hb:
                continue
            ii = slice(max(i - 1, 1), min(i + 2, n - 1))
            jj = slice(max(j - 1, 1), min(j + 2, n - 1))
            link = float(box[ii, jj].max())  # the guard-ring neighbour most likely lit
            p_none *= 1.0 - float(box[i, j]) * link
    return 1.0 - p_none


def target_backgrounds(
    a: np.ndarray, r: int, c: int, box_px: int = 7
) -> list[tuple[float, np.ndarray]]:
    """The backgrounds the console's target-aware Eq. (4) takes for the noise-free pattern
    ``a`` (noise sigma units) whose brightest pixel is row ``r``, column ``c``, with their
    probabilities (module docstring): the 7x7 rim while the extent (8-connected pixels >= 3
    sigma in the frame) stays within the 5x5 guard, else the rim of the extent's box (at least
    the 7x7 box) grown by the guard. The extent is decided per frame on noisy pixels, so a
    target whose light on the 7x7 rim is near 3 sigma is measured one way or the other frame
    by frame: weighting the two by that probability keeps the expectation continuous in
    range."""
    from scipy.ndimage import label

    hb = box_px // 2
    seven = _rect_rim(a, (c - hb, r - hb, c + hb, r + hb))
    if seven is None:
        raise PatternTooSmallError("pattern too small for the 7x7 box")
    p = _extent_probability(a, r, c, hb)
    if p < 1e-9:
        return [(1.0, seven)]
    x0, y0, x1, y1 = c - hb, r - hb, c + hb, r + hb
    if a[r, c] >= EXTENT_SIGMA:
        labels, _ = label(a >= EXTENT_SIGMA, structure=np.ones((3, 3), bool))
        ys, xs = np.nonzero(labels == labels[r, c])
        x0, y0 = min(x0, int(xs.min())), min(y0, int(ys.min()))
        x1, y1 = max(x1, int(xs.max())), max(y1, int(ys.max()))
    g = GUARD_PX + 1
    extent = _rect_rim(a, (x0 - g, y0 - g, x1 + g, y1 + g))
    if extent is None:
        raise PatternTooSmallError("pattern too small for the target's background rim")
    return [(1.0 - p, seven), (p, extent)]


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
    return _readings(a, search_px, box_px, ddof, (background,))[0]


def _readings(a, search_px: int, box_px: int, ddof: int, backgrounds: tuple[str, ...]):
    """:func:`readings_of_patterns` for several background rules at once (one peak search):
    shape (len(backgrounds), ...)."""
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
    out = np.zeros((len(backgrounds), len(pats)))
    for j, (pat, y, x) in enumerate(zip(pats, r, col, strict=True)):
        for b, background in enumerate(backgrounds):
            if background == "target":
                rims = target_backgrounds(pat, int(y), int(x), box_px)
            else:
                seven = _rect_rim(pat, (x - hb, y - hb, x + hb, y + hb))
                assert seven is not None  # the reach check above keeps the box inside
                rims = [(1.0, seven)]
            for weight, rim in rims:
                lam = float(np.sum((rim - rim.mean()) ** 2))
                out[b, j] += weight * (peak[j] - rim.mean()) * rim_std_factor(rim.size, ddof, lam)
    return out.reshape((len(backgrounds), *lead))


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
    out = np.empty((len(backgrounds), *amp.shape))
    cache: dict[tuple[float, float, int], np.ndarray] = {}
    for idx in np.ndindex(amp.shape):
        half = base_half
        if "target" in backgrounds:  # room for the target, the guard and the rim around it
            half += int(np.ceil(float(d[idx]) / 2 + 3.0 * float(s[idx])))
        while True:
            key = (float(d[idx]), float(s[idx]), half)
            if key not in cache:
                cache[key] = pixel_patterns(
                    psf,
                    fill_factor,
                    ph_x,
                    ph_y,
                    half_size_px=half,
                    target_square_px=key[0],
                    target_sigma_px=key[1],
                )
            try:
                readings = _readings(
                    float(amp[idx]) * cache[key], search_px, box_px, ddof, backgrounds
                )
                break
            except PatternTooSmallError:
                if half >= MAX_HALF_PX:
                    raise
                half = min(2 * half, MAX_HALF_PX)  # a bright target's 3-sigma extent is wide
        for b in range(len(backgrounds)):
            out[(b, *idx)] = float(np.sum(weights * readings[b]))
    return {rule: out[b] for b, rule in enumerate(backgrounds)}


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
