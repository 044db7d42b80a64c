"""The target's footprint on the pixels: a square of side D (or the paper's Gaussian of sigma_t)
convolved with the PSF, integrated over each pixel's active area (paper Eq. 2 and section 8).

Conventions are :mod:`snrmon.model.pvf`'s: lengths in pixel pitches, the active detector a centred
square of side a = sqrt(FF) (FF an AREA fill factor), every PSF of unit energy, the target
normalised to the same total flux, phases uniform over one pixel cell.

* :func:`average_pvf_square`: the phase-averaged ensquared energy of a D x D square target
  convolved with the PSF. It is continuous in D: for D -> 0 it is the point-source average PVF
  of :func:`snrmon.model.pvf.average_pvf`; for a target that covers the pixel and the PSF's core it
  tends to FF / D^2, so that ``point signal x PVF`` becomes the resolved, pixel-filling radiance
  formula of the paper (section 2) exactly. This replaces the paper's switch between the two.
* :func:`average_pvf_outline`: the same for a target given as its outline (the segmented pixels
  of a close stop, each a square of ``cell_px`` at this range), the "outline" footprint.
* :func:`pixel_patterns`: the fraction of the energy on every pixel of a (2h+1)^2 window for a
  grid of sub-pixel phases at once (square or Gaussian target), used by the expected Eq. (4)
  reading (:mod:`snrmon.model.eq4`) and the PSF estimate from flight data.

Numerics: the OTF is integrated on a Cartesian frequency grid (trapezoid over the quadrant
f >= 0 with the even multiplicities), which by Poisson summation is exact up to aliasing at the
grid's spatial period (``period_px``, 256 px for the PVF table: the Airy wings beyond it carry
< 0.1 % of the energy). The square's transform sinc(D fx) sinc(D fy) is separable, so a whole
table of D values costs one matrix product.
"""

from __future__ import annotations

import functools
import itertools
import math

import numpy as np
from scipy.interpolate import PchipInterpolator
from scipy.special import ndtr

from snrmon.model.psf import AiryGaussianPsf, GaussianPsf, Psf

_TABLE_PERIOD_PX = 256.0
_PATTERN_PERIOD_PX = 128.0
_D_TABLE_MAX_PX = 64.0
_N_D_TABLE = 193


_SINGLE_THREAD_MACS = 200_000  # OpenBLAS threads a product above 65536 x 4 multiply-adds


def matmul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``a @ b`` in blocks that BLAS runs on one thread. These products are small (~100 x
    200 x 200), and a multi-threaded OpenBLAS on a busy 2-core machine took them 10-100x
    longer now and then (16 ms against 0.2 ms for 175 x 218 x 218, 95th percentile of 200),
    numpy's own loop (einsum) 3-5x longer every time; in blocks of < 200000 multiply-adds,
    below OpenBLAS's threading threshold, they take 0.6 ms at the 95th percentile."""
    m, k = a.shape
    n = b.shape[1]
    if m * k * n <= _SINGLE_THREAD_MACS:
        return a @ b
    rows = max(1, min(m, _SINGLE_THREAD_MACS // (k * min(n, 16))))
    cols = max(1, _SINGLE_THREAD_MACS // (rows * k))
    out = np.empty((m, n), dtype=np.result_type(a, b))
    for i in range(0, m, rows):
        for j in range(0, n, cols):
            out[i : i + rows, j : j + cols] = a[i : i + rows] @ b[:, j : j + cols]
    return out


def _check_ff(fill_factor: float) -> float:
    ff = float(fill_factor)
    if not 0.0 < ff <= 1.0:
        raise ValueError(f"fill factor (area) must be in (0, 1], got {fill_factor!r}")
    return ff


def _check_sizes(d_px, what: str = "target size") -> np.ndarray:
    d = np.asarray(d_px, dtype=float)
    if np.any(~np.isfinite(d)) or np.any(d < 0):
        raise ValueError(f"{what} must be >= 0 px, got {d_px!r}")
    return d


@functools.lru_cache(maxsize=32)
def otf_grid(psf: Psf, period_px: float) -> tuple[np.ndarray, np.ndarray]:
    """Frequencies f_k >= 0 [cycles/pitch] up to the PSF's cutoff and the matrix
    M[j, k] = OTF(f_j, f_k) dfx dfy m_j m_k (m = 1 at f = 0, else 2: the other quadrants),
    so that integral OTF(f) u(fx) u(fy) df = u^T M u for even functions u."""
    if isinstance(psf, AiryGaussianPsf):
        # the blur's MTF is separable and the Airy's cutoffs (so its grid) are the blurred
        # PSF's: one Airy grid serves the diffraction PSF and every blur of it
        f, m_airy = otf_grid(psf.airy, period_px)
        g = np.exp(-2.0 * math.pi**2 * float(psf.sigma_px) ** 2 * f * f)
        m = m_airy * g[:, None] * g[None, :]
        m.setflags(write=False)
        return f, m
    top = max(cut for _, _, cut in psf.components())
    n = min(math.ceil(top * period_px), 4096)
    step = top / n
    f = np.arange(n + 1) * step
    # The OTF is radial: on the grid a function of j^2 + k^2, evaluated once per distinct sum
    # (a third of the pairs), at radius step sqrt(j^2 + k^2), ascending; each component (an
    # Airy has one per wavelength) only inside its own cutoff, beyond which it is ~0
    # (psf.components): from the first radius up to it. The sums are marked in a table of
    # all of them up to 2 n^2 (no sort).
    i = np.arange(n + 1, dtype=np.int32)
    sums = i[:, None] ** 2 + i[None, :] ** 2
    present = np.zeros(2 * n * n + 1, bool)
    present[sums] = True
    distinct = np.flatnonzero(present)
    radius = step * np.sqrt(distinct)
    by_radius = np.zeros(distinct.size)
    for w, fn, cut in psf.components():
        inside = int(np.searchsorted(radius, cut))  # the radii < cut
        by_radius[:inside] += w * fn(radius[:inside])
    which = np.empty(present.size, np.int32)
    which[distinct] = np.arange(distinct.size, dtype=np.int32)
    otf = by_radius[which[sums]]
    mult = np.full(n + 1, 2.0)
    mult[0] = 1.0
    otf *= (step * mult)[:, None]
    otf *= (step * mult)[None, :]
    f.setflags(write=False)
    otf.setflags(write=False)
    return f, otf


def _pixel_kernel(f: np.ndarray, fill_factor: float) -> np.ndarray:
    """1-D transform of the phase-averaged pixel: sqrt(FF) sinc(a f) sinc(f) (a = sqrt(FF))."""
    a = math.sqrt(fill_factor)
    return a * np.sinc(a * f) * np.sinc(f)


def _direct_pvf_square(psf: Psf, fill_factor: float, d_px: np.ndarray, period_px: float):
    f, m = otf_grid(psf, period_px)
    k = _pixel_kernel(f, fill_factor)[:, None] * np.sinc(np.outer(f, d_px))
    return np.einsum("jd,jd->d", matmul(m, k), k)


_TABLE_CHUNK = 32  # table nodes computed together, as far as the sizes asked for need


def _table_nodes() -> np.ndarray:
    # h(D) = PVF(D) (1 + D^2) / FF is smooth and O(1) everywhere: PVF0 / FF at D = 0, and
    # -> 1 for large D (the pixel-filling limit); quadratic spacing puts nodes where it bends.
    return _D_TABLE_MAX_PX * np.linspace(0.0, 1.0, _N_D_TABLE) ** 2


@functools.lru_cache(maxsize=256)
def _square_table_chunk(psf: Psf, fill_factor: float, chunk: int) -> np.ndarray:
    """h(D) at the table's nodes ``chunk`` x 32 to 32 further (always the same nodes
    together: a node's value does not depend on what else was asked)."""
    d = _table_nodes()[chunk * _TABLE_CHUNK : (chunk + 1) * _TABLE_CHUNK]
    h = _direct_pvf_square(psf, fill_factor, d, _TABLE_PERIOD_PX) * (1.0 + d * d) / fill_factor
    h.setflags(write=False)
    return h


@functools.lru_cache(maxsize=64)
def _square_table(psf: Psf, fill_factor: float, chunks: int) -> PchipInterpolator:
    """PCHIP through the table's first ``chunks`` chunks of nodes. Its pieces below the last
    two nodes are those of the whole table (PCHIP's slope at a node is set by its neighbours
    alone, the ends' by the end): the table is computed only as far as the sizes need."""
    d = _table_nodes()[: chunks * _TABLE_CHUNK]
    h = np.concatenate([_square_table_chunk(psf, fill_factor, c) for c in range(chunks)])
    return PchipInterpolator(d, h)


def _square_table_for(psf: Psf, fill_factor: float, d_max_px: float) -> PchipInterpolator:
    """:func:`_square_table` far enough to interpolate up to ``d_max_px`` (<= the table's
    end): the piece that holds it and the nodes that set its end slopes."""
    nodes = _table_nodes()
    piece = int(np.searchsorted(nodes, d_max_px, side="right")) - 1
    need = min(piece + 3, nodes.size)  # nodes up to piece + 2: the piece's far slope is interior
    return _square_table(psf, fill_factor, -(-need // _TABLE_CHUNK))


def average_pvf_square(psf: Psf, fill_factor: float, d_px) -> np.ndarray | float:
    """Phase-averaged ensquared energy of a square target of side ``d_px`` (scalar or array)
    convolved with ``psf``: continuous from the point-source average PVF (D = 0) to the
    pixel-filling FF / D^2 of a resolved target. Interpolated (PCHIP, relative error < 1e-4) on
    a cached table up to D = 64 px; beyond, FF/D^2 times the table's last energy share, which
    tends to 1 as the PSF wings fall inside the square (their energy falls as 1/D)."""
    ff = _check_ff(fill_factor)
    d = _check_sizes(d_px)
    inside = np.minimum(d, _D_TABLE_MAX_PX)
    table = _square_table_for(psf, ff, float(np.max(inside, initial=0.0)))
    h = table(inside)
    far = d > _D_TABLE_MAX_PX
    if np.any(far):
        deficit = 1.0 - float(table(_D_TABLE_MAX_PX))
        h = np.where(far, 1.0 - deficit * _D_TABLE_MAX_PX / np.where(far, d, 1.0), h)
    out = ff * h / (1.0 + d * d)
    return float(out) if out.ndim == 0 else out


def average_pvf_outline(psf: Psf, fill_factor: float, outline, cell_px) -> np.ndarray | float:
    """Phase-averaged energy on the pixel that holds the area centroid of a target made of the
    cells of ``outline`` (a :class:`snrmon.model.target.Outline`), each a square of side
    ``cell_px`` (scalar or array: the outline's pixel at the drone over this range's pixel
    footprint), convolved with ``psf``: :func:`average_pvf_square` with the segmented shape in
    place of the square of the same area (paper sections 3 and 10: the UAV's shape puts
    background and target in one rectangle).

    The target's transform is the sum over its cells of sinc(s fx) sinc(s fy) exp(-2 pi i f.x_k)
    over their number; against an OTF even in fx and in fy only its cos(2 pi fx x) cos(2 pi fy
    y) part integrates to non-zero, so with the cells on a lattice (columns i, rows j) the PVF
    is the mean over the outline's cells of (X^T M Y)[i, j], X and Y the lattice's columns' and
    rows' cosines times the pixel kernel and the cell's sinc: two small matrix products a size.
    Exact up to aliasing at the grid's 256-px period, as the square's table."""
    ff = _check_ff(fill_factor)
    s = _check_sizes(cell_px, "outline cell")
    x_m, y_m, mask = outline.offsets_m()
    unit = 1.0 / float(outline.pixel_m)  # positions in cells: x_px = (x_m / pixel_m) s
    f, m = otf_grid(psf, _TABLE_PERIOD_PX)
    k = _pixel_kernel(f, ff)
    cells = float(mask.sum())
    out = np.empty(s.size)
    for n, size in enumerate(np.atleast_1d(s)):
        w = k * np.sinc(size * f)
        xc = w[:, None] * np.cos(2.0 * math.pi * np.outer(f, x_m * unit * size))
        yc = w[:, None] * np.cos(2.0 * math.pi * np.outer(f, y_m * unit * size))
        g = matmul(xc.T, matmul(m, yc))  # (columns, rows)
        out[n] = float(np.sum(g.T[mask])) / cells
    return float(out[0]) if s.ndim == 0 else out.reshape(s.shape)


@functools.lru_cache(maxsize=64)
def _pattern_weights(psf: Psf, fill_factor: float, d_px: float, sigma_px: float):
    """(omega = 2 pi f, u, M): the pattern is (C u) M (C u)^T, C the cosines."""
    f, m = otf_grid(psf, _PATTERN_PERIOD_PX)
    a = math.sqrt(fill_factor)
    u = a * np.sinc(a * f)  # the pixel's active square, not phase-averaged
    if d_px > 0:
        u = u * np.sinc(d_px * f)
    if sigma_px > 0:
        u = u * np.exp(-2.0 * math.pi**2 * sigma_px**2 * f * f)
    u.setflags(write=False)
    return 2.0 * math.pi * f, u, m


def pixel_patterns(
    psf: Psf,
    fill_factor: float,
    dx_px,
    dy_px,
    *,
    half_size_px: int = 3,
    target_square_px: float = 0.0,
    target_sigma_px: float = 0.0,
) -> np.ndarray:
    """Energy fractions on the ACTIVE area of each pixel of a (2h+1)^2 window, for every
    combination of the phases ``dy_px`` x ``dx_px`` (arrays): shape (n_dy, n_dx, 2h+1, 2h+1),
    rows = y, columns = x; the target's centroid at (dx, dy) pitches from the middle pixel's
    centre. The target is a square of side ``target_square_px`` and/or a Gaussian of
    ``target_sigma_px`` (0: a point). Averaged over phases uniform in the cell, the middle pixel
    gives :func:`average_pvf_square` (or :func:`snrmon.model.pvf.average_pvf` for a Gaussian
    target)."""
    ff = _check_ff(fill_factor)
    h = int(half_size_px)
    if h < 0:
        raise ValueError(f"half_size_px must be >= 0, got {half_size_px!r}")
    d = float(_check_sizes(target_square_px))
    s = float(_check_sizes(target_sigma_px, "target sigma"))
    dx = tuple(np.atleast_1d(np.asarray(dx_px, dtype=float)).tolist())
    dy = tuple(np.atleast_1d(np.asarray(dy_px, dtype=float)).tolist())
    if isinstance(psf, GaussianPsf):
        # separable and closed-form at any width, a delta (sigma 0) included: the OTF grid
        # cannot hold a PSF much narrower than a pixel (its cutoff ~1.2 / sigma needs
        # 128 / sigma frequencies; at 4096 of them sigma 0.001 px aliased at a 3.5-px period)
        sigma = math.hypot(float(psf.sigma_px), s)
        fy = _gaussian_fractions_1d(np.asarray(dy), sigma, d, ff, h)
        fx = fy if dx == dy else _gaussian_fractions_1d(np.asarray(dx), sigma, d, ff, h)
        return fy[:, None, :, None] * fx[None, :, None, :]
    omega, u, m = _pattern_weights(psf, ff, d, s)
    grid = omega.tobytes()  # omega = 2 pi f on the PSF's grid (otf_grid)
    cy = _cosines(grid, dy, h) * u
    cx = cy if dx == dy else _cosines(grid, dx, h) * u
    out = matmul(matmul(cy, m), cx.T)  # (n_dy * n, n_dx * n)
    n = 2 * h + 1
    return out.reshape(len(dy), n, len(dx), n).transpose(0, 2, 1, 3)


def _gaussian_fractions_1d(
    phases: np.ndarray, sigma_px: float, d_px: float, fill_factor: float, h: int
) -> np.ndarray:
    """(n_phases, 2h+1): the share of a 1-D box of width ``d_px`` (0: a point) blurred by a
    Gaussian of ``sigma_px`` (0: none) centred at each phase that falls on the active interval
    (width sqrt(FF)) of pixels -h..h. The active interval's share is a difference of the
    box-blurred profile's antiderivative at its two ends, itself (1/D) times differences of
    the Gaussian CDF's antiderivative, sigma G(x / sigma) with G(z) = z Phi(z) + phi(z)
    (x+ = max(x, 0) at sigma 0)."""
    from snrmon.model.pvf import _g_int

    a = 0.5 * math.sqrt(fill_factor)
    k = np.arange(-h, h + 1, dtype=float)
    rel = k[None, :] - phases[:, None]  # each pixel's centre from the target's
    lo, hi = rel - a, rel + a

    def cdf(x):  # the blurred point's share below x
        if sigma_px == 0.0:
            return np.where(x > 0, 1.0, np.where(x < 0, 0.0, 0.5))
        return ndtr(x / sigma_px)

    def cdf_int(x):  # its antiderivative
        if sigma_px == 0.0:
            return np.maximum(x, 0.0)
        return sigma_px * _g_int(x / sigma_px)

    if d_px == 0.0:
        return cdf(hi) - cdf(lo)
    b = 0.5 * d_px
    return (cdf_int(hi + b) - cdf_int(hi - b) - cdf_int(lo + b) + cdf_int(lo - b)) / d_px


@functools.lru_cache(maxsize=64)
def _cosines(grid: bytes, phases: tuple[float, ...], h: int) -> np.ndarray:
    """cos(omega (k - delta)) for every (phase delta, pixel k in -h..h) and frequency omega of
    the grid ``grid`` (its bytes): the even transform of a pattern. The same for every target
    size (the expected reading asks for dozens over one phase grid)."""
    omega = np.frombuffer(grid)
    k = np.arange(-h, h + 1, dtype=float)
    out = np.cos(((k[None, :] - np.asarray(phases)[:, None]).reshape(-1))[:, None] * omega)
    out.setflags(write=False)
    return out


def phase_grid(n: int) -> np.ndarray:
    """``n`` midpoints of equal steps over the half cell [0, 0.5): with a PSF and target
    symmetric under x -> -x, y -> -y, an average over them is the average over the cell."""
    if n < 1:
        raise ValueError(f"phase grid needs n >= 1, got {n}")
    return (np.arange(n) + 0.5) / (2.0 * n)


def phase_nodes(psf: Psf, fill_factor: float, n: int) -> tuple[np.ndarray, np.ndarray]:
    """Phases over the half cell [0, 0.5) and their weights (summing to 1) for an average over
    phases uniform in the cell: :func:`phase_grid`'s ``n`` equal midpoints, except for a
    Gaussian PSF narrower than their step (1 / (2 n) px), a delta included. Its point's light
    leaves the active area within 3 sigma of the active edge (phase sqrt(FF) / 2, or the
    cell's), so what a pixel holds is nearly a step in phase there, which equal midpoints
    weight by where they happen to fall (FF 0.8: 4 of 5 inside, 0.64 of the cell in 2-D
    against the 0.8 it is); the half cell is then cut at the edge +- 3 sigma, ``n`` midpoints
    in each piece, each weighted by its piece's length: the pixel-phase integral taken
    directly (for a delta, the two sides of the step exactly)."""
    ph = phase_grid(n)
    if not (isinstance(psf, GaussianPsf) and psf.sigma_px < 0.5 / n):
        return ph, np.full(n, 1.0 / n)
    edge, spread = 0.5 * math.sqrt(_check_ff(fill_factor)), 3.0 * float(psf.sigma_px)
    cuts = np.unique(np.clip([0.0, edge - spread, edge, edge + spread, 0.5], 0.0, 0.5))
    nodes = [lo + (hi - lo) * 2.0 * ph for lo, hi in itertools.pairwise(cuts)]
    weights = [np.full(n, (hi - lo) / n / 0.5) for lo, hi in itertools.pairwise(cuts)]
    return np.concatenate(nodes), np.concatenate(weights)
