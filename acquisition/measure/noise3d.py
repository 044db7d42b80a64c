"""3D noise of a frame cube (D'Agostino and Webb, Proc. SPIE 1488, 1991) with the finite-size bias
removed and 95 % confidence intervals (Haefner and Burks, Appl. Opt. 54(15) 4907, 2015).

The cube U(t, v, h) holds T frames of V rows and H columns of a uniform scene (a blackbody, a
clear-sky region). The directional averaging operators are

* ``D_t U`` = the mean over t (frames): a (V, H) image, the same for every t;
* ``D_v U`` = the mean over v (rows); ``D_h U`` = the mean over h (columns);

they commute, and ``(1 - D_x)`` removes what does not change along x. The seven noise components
(D'Agostino and Webb's decomposition) and the mean S are

====  ===================================  ==================================================
name  component N_x                        what it is
====  ===================================  ==================================================
S     D_t D_v D_h U                        the mean level
t     (1 - D_t) D_v D_h U                  frame-to-frame flicker of the whole frame
v     (1 - D_v) D_t D_h U                  fixed row noise
h     (1 - D_h) D_t D_v U                  fixed column noise
tv    (1 - D_t)(1 - D_v) D_h U             row noise that changes every frame
th    (1 - D_t)(1 - D_h) D_v U             column noise that changes every frame
vh    (1 - D_v)(1 - D_h) D_t U             fixed-pattern non-uniformity (pixel to pixel)
tvh   (1 - D_t)(1 - D_v)(1 - D_h) U        random spatio-temporal noise
====  ===================================  ==================================================

and U = S + the sum of the seven. Each N_x lives on the directions in its name (N_t has T values,
N_tv T x V, ...) and has zero mean.

Figures (all in the cube's units, DN):

* ``sigma[x]``: the sample standard deviation (ddof 1) of N_x over its ``n_x`` values (T for t,
  T V for tv, ...): ``sqrt(sum N_x^2 / (n_x - 1))``, D'Agostino and Webb's directional estimate.
  ``sigma["total"]`` is the sample standard deviation (ddof 1) of the whole cube.
* ``sigma_corrected[x]``: the finite-size bias removed. With the seven components independent and
  each white along its own directions, the unbiased directional variance
  ``u_x = sum N_x^2 / nu_x`` (``nu_x`` the product of (n - 1) over x's directions: T - 1 for t,
  (T - 1)(V - 1) for tv, ...) has the expectation ``sum over y containing x of sigma_y^2 / (the
  product of the sizes of the directions y has beyond x)``: for example
  ``E[u_t] = s_t^2 + s_tv^2 / V + s_th^2 / H + s_tvh^2 / (V H)``. Inverting that triangular system
  (inclusion-exclusion) gives the unbiased estimates::

      s_tvh^2 = u_tvh
      s_tv^2  = u_tv - u_tvh / H        s_th^2 = u_th - u_tvh / V        s_vh^2 = u_vh - u_tvh / T
      s_t^2   = u_t - u_tv / V - u_th / H + u_tvh / (V H)
      s_v^2   = u_v - u_tv / T - u_vh / H + u_tvh / (T H)
      s_h^2   = u_h - u_th / T - u_vh / V + u_tvh / (T V)

  ``sigma_corrected[x]`` is the square root, 0 where the estimate of the variance is negative
  (noise of the estimate larger than the component); ``sigma_corrected["total"]`` is the square
  root of the sum of the seven variance estimates (the variance of one pixel sample).
* ``ci95[x]``: the 95 % confidence interval of ``sigma_corrected[x]``, the square roots of the
  interval of its variance (lower end clipped at 0). With Gaussian noise each ``u_y`` is an
  independent ``E[u_y] chi^2_{nu_y} / nu_y``; the variance estimate is a linear combination of
  them with signs of both kinds, whose interval is the modified large-sample (MLS) interval of
  Ting, Burdick, Graybill, Jeyaratnam and Lu (J. Statist. Comput. Simul. 35, 1990), exact when
  one ``u_y`` alone makes the estimate (``tvh``).

Memory: the cube is reduced to its marginal means (frame means, row and column means of every
frame, the temporal mean image, the sum of squares), accumulated a chunk of frames at a time
(:class:`Noise3dSums`), so a long calibration capture is never converted to float64 whole.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from itertools import combinations

import numpy as np
from scipy import stats

COMPONENTS: tuple[str, ...] = ("t", "v", "h", "tv", "th", "vh", "tvh")
"""The seven components, in D'Agostino and Webb's order."""
FIGURES: tuple[str, ...] = (*COMPONENTS, "total")
CONFIDENCE = 0.95
ROUNDING_FLOOR = 1e-6
"""A component whose rms is below this share of the total noise is taken as exactly 0 (float64
rounding leaves ~1e-8 of it in components a synthetic cube does not have)."""
_CHUNK_VALUES = 2**22  # pixels converted to float64 at a time (32 MB)


@dataclass(frozen=True)
class Noise3d:
    """The 3D noise of one T x V x H cube (module docstring); every figure in the cube's units.

    ``sigma``, ``sigma_corrected`` and ``ci95`` are keyed by :data:`FIGURES`; ``dof`` by
    :data:`COMPONENTS` (``nu_x``, the degrees of freedom of ``u_x``).
    """

    frames: int
    rows: int
    cols: int
    mean: float
    sigma: Mapping[str, float]
    sigma_corrected: Mapping[str, float]
    ci95: Mapping[str, tuple[float, float]]
    dof: Mapping[str, int]

    def scaled(self, factor: float) -> Noise3d:
        """Every figure times ``factor`` (> 0), e.g. 1 / SiTF [K per DN] for kelvin; the mean too
        (an offset would not make it a temperature: use the calibration for that)."""
        if not (factor > 0 and math.isfinite(factor)):
            raise ValueError(f"a noise scale must be a positive number, got {factor!r}")
        return Noise3d(
            self.frames,
            self.rows,
            self.cols,
            self.mean * factor,
            {k: v * factor for k, v in self.sigma.items()},
            {k: v * factor for k, v in self.sigma_corrected.items()},
            {k: (lo * factor, hi * factor) for k, (lo, hi) in self.ci95.items()},
            dict(self.dof),
        )

    def figures(self, unit: str = "dn") -> dict[str, dict]:
        """``{"sigma_<unit>": {...}, "sigma_corrected_<unit>": {...}, "ci95_<unit>": {x: [lo,
        hi]}}``: the JSON fields of ``snrmon noise``."""
        return {
            f"sigma_{unit}": {k: self.sigma[k] for k in FIGURES},
            f"sigma_corrected_{unit}": {k: self.sigma_corrected[k] for k in FIGURES},
            f"ci95_{unit}": {k: list(self.ci95[k]) for k in FIGURES},
        }

    @property
    def peak_pixel_noise(self) -> float:
        """sqrt(sigma_tvh^2 + sigma_vh^2) (bias-corrected): the noise of one pixel against the
        others of one frame once row, column and frame offsets are gone, as Eq. (4)'s rim sees
        it."""
        return math.hypot(self.sigma_corrected["tvh"], self.sigma_corrected["vh"])


def _sizes_of(name: str, sizes: Mapping[str, int]) -> int:
    return math.prod(sizes[d] for d in name)


def correction_coefficients(frames: int, rows: int, cols: int) -> dict[str, dict[str, float]]:
    """``c[x][y]``: the unbiased variance of component x is ``sum_y c[x][y] u_y`` (module
    docstring), y running over the components that contain x's directions."""
    sizes = {"t": frames, "v": rows, "h": cols}
    out: dict[str, dict[str, float]] = {}
    for x in COMPONENTS:
        coeffs = {}
        for y in COMPONENTS:
            if set(x) <= set(y):
                extra = [d for d in y if d not in x]
                coeffs[y] = (-1.0) ** len(extra) / math.prod(sizes[d] for d in extra)
        out[x] = coeffs
    return out


@functools.lru_cache(maxsize=512)
def _g(a: float, n: int) -> float:
    """1 - 1 / F(a; n, inf), F(a) the upper a point (Ting et al.'s G)."""
    return 1.0 - n / float(stats.chi2.isf(a, n))


@functools.lru_cache(maxsize=512)
def _h(a: float, n: int) -> float:
    """1 / F(1 - a; n, inf) - 1 (Ting et al.'s H)."""
    return n / float(stats.chi2.ppf(a, n)) - 1.0


@functools.lru_cache(maxsize=512)
def _f_points(a: float, n1: int, n2: int) -> tuple[float, float]:
    """The upper and lower a points of F(n1, n2)."""
    return float(stats.f.isf(a, n1, n2)), float(stats.f.ppf(a, n1, n2))


def mls_interval(
    estimates: Mapping[str, float],
    dof: Mapping[str, int],
    coefficients: Mapping[str, float],
    confidence: float = CONFIDENCE,
) -> tuple[float, float]:
    """Two-sided interval of ``sum_y c_y E[u_y]`` from independent ``u_y ~ E[u_y] chi^2_nu /
    nu`` (the modified large-sample method, Ting et al. 1990; exact for one term)."""
    a = (1.0 - confidence) / 2.0
    terms = [(c, estimates[y], dof[y]) for y, c in coefficients.items() if c != 0.0]
    pos = [(c, s, n) for c, s, n in terms if c > 0]
    neg = [(-c, s, n) for c, s, n in terms if c < 0]
    value = sum(c * s for c, s, _ in terms)

    def g(n: int) -> float:
        return _g(a, n)

    def h(n: int) -> float:
        return _h(a, n)

    def star(group: list[tuple[float, float, int]]) -> float:
        total = 0.0
        for (c1, s1, n1), (c2, s2, n2) in combinations(group, 2):
            k = (g(n1 + n2) ** 2 * (n1 + n2) ** 2 / (n1 * n2) - g(n1) ** 2 * n1 / n2) - (
                g(n2) ** 2 * n2 / n1
            )
            total += k / (len(group) - 1) * c1 * c2 * s1 * s2
        return total

    low = sum((g(n) * c * s) ** 2 for c, s, n in pos) + sum((h(n) * c * s) ** 2 for c, s, n in neg)
    high = sum((h(n) * c * s) ** 2 for c, s, n in pos) + sum((g(n) * c * s) ** 2 for c, s, n in neg)
    for cq, sq, nq in pos:
        for cr, sr, nr in neg:
            f_hi, f_lo = _f_points(a, nq, nr)
            g_qr = ((f_hi - 1.0) ** 2 - g(nq) ** 2 * f_hi**2 - h(nr) ** 2) / f_hi
            h_qr = ((1.0 - f_lo) ** 2 - h(nq) ** 2 * f_lo**2 - g(nr) ** 2) / f_lo
            low += g_qr * cq * cr * sq * sr
            high += h_qr * cq * cr * sq * sr
    low += star(pos)
    high += star(neg)
    return value - math.sqrt(max(low, 0.0)), value + math.sqrt(max(high, 0.0))


class Noise3dSums:
    """The marginal sums of a cube, frame after frame: ``add`` frames (V, H) or chunks (n, V, H),
    then :meth:`result`. Memory: one (V, H) image and V + H + 1 numbers per frame.

    Integer pixels (camera counts) are summed in int64 after subtracting an integer offset (the
    first frame's rounded mean): every sum, the sum of squares included, is exact. Float pixels
    are summed in float64 after the same offset (no cancellation in the sum of squares)."""

    def __init__(self, rows: int, cols: int) -> None:
        if rows < 2 or cols < 2:
            raise ValueError(f"3D noise needs at least 2 rows and 2 columns, got {rows} x {cols}")
        self.rows, self.cols = int(rows), int(cols)
        self._offset: float | None = None
        self._image = np.zeros((self.rows, self.cols))
        self._row_sums: list[np.ndarray] = []  # (n, V) per chunk: the sum over h
        self._col_sums: list[np.ndarray] = []  # (n, H): the sum over v
        self._squares: float = 0.0
        self.frames = 0

    def add(self, frames: np.ndarray) -> None:
        cube = np.asarray(frames)
        if cube.ndim == 2:
            cube = cube[None]
        if cube.ndim != 3 or cube.shape[1:] != (self.rows, self.cols):
            raise ValueError(
                f"3D noise of {self.rows} x {self.cols} frames, got an array of shape {cube.shape}"
            )
        if cube.dtype.kind not in "uif":
            raise ValueError(f"3D noise needs numeric pixels, got dtype {cube.dtype}")
        exact = cube.dtype.kind in "ui"
        step = max(1, _CHUNK_VALUES // (self.rows * self.cols))
        for i in range(0, cube.shape[0], step):
            chunk = cube[i : i + step]
            if self._offset is None:
                self._offset = float(np.round(np.mean(chunk[0], dtype=np.float64)))
            x: np.ndarray
            if exact:
                x = chunk.astype(np.int64) - int(self._offset)
                self._squares += int(np.einsum("ijk,ijk->", x, x))
            else:
                x = chunk.astype(np.float64) - self._offset
                self._squares += float(np.einsum("ijk,ijk->", x, x))
            self._row_sums.append(x.sum(axis=2).astype(np.float64))
            self._col_sums.append(x.sum(axis=1).astype(np.float64))
            self._image += x.sum(axis=0)
            self.frames += x.shape[0]

    def mean_image(self) -> np.ndarray:
        """D_t U: the temporal mean of every pixel of the frames added (V, H)."""
        if self.frames == 0:
            raise ValueError("no frames added")
        return self._image / self.frames + (self._offset or 0.0)

    def result(self, confidence: float = CONFIDENCE) -> Noise3d:
        """The figures of the frames added (module docstring); at least 2 frames."""
        T, V, H = self.frames, self.rows, self.cols
        if T < 2:
            raise ValueError(f"3D noise needs at least 2 frames, got {T}")
        r = np.concatenate(self._row_sums) / H  # D_h U: (T, V)
        c = np.concatenate(self._col_sums) / V  # D_v U: (T, H)
        f = r.mean(axis=1)  # D_v D_h U: (T,)
        p = self._image / T  # D_t U: (V, H)
        m = float(f.mean())
        rbar, cbar = r.mean(axis=0), c.mean(axis=0)
        n = {
            "t": f - m,
            "v": rbar - m,
            "h": cbar - m,
            "tv": r - f[:, None] - rbar[None, :] + m,
            "th": c - f[:, None] - cbar[None, :] + m,
            "vh": p - rbar[:, None] - cbar[None, :] + m,
        }
        ss = {k: float(np.vdot(v, v)) for k, v in n.items()}
        sizes = {"t": T, "v": V, "h": H}
        total_ss = max(float(self._squares) - T * V * H * m * m, 0.0)
        # the sum of squares splits exactly into the seven, each counted once per repeat
        # along the directions it does not have: N_tvh's is what is left
        repeated = sum(ss[k] * ((T * V * H) // _sizes_of(k, sizes)) for k in ss)
        ss["tvh"] = max(total_ss - repeated, 0.0)
        # float64 rounding leaves ~1e-8 of the total in a component the cube does not have (a
        # synthetic one); below a millionth of the total noise a component is exactly 0
        floor = (ROUNDING_FLOOR**2) * total_ss / (T * V * H)
        ss = {k: v if v > floor * _sizes_of(k, sizes) else 0.0 for k, v in ss.items()}
        dof = {k: math.prod(sizes[d] - 1 for d in k) for k in COMPONENTS}
        u = {k: ss[k] / dof[k] for k in COMPONENTS}
        sigma = {k: math.sqrt(ss[k] / (_sizes_of(k, sizes) - 1)) for k in COMPONENTS}
        sigma["total"] = math.sqrt(total_ss / (T * V * H - 1))
        coeffs = correction_coefficients(T, V, H)
        coeffs["total"] = {y: sum(coeffs[x].get(y, 0.0) for x in COMPONENTS) for y in COMPONENTS}
        corrected, ci = {}, {}
        for k in FIGURES:
            var = sum(cy * u[y] for y, cy in coeffs[k].items())
            lo, hi = mls_interval(u, dof, coeffs[k], confidence)
            corrected[k] = math.sqrt(max(var, 0.0))
            ci[k] = (math.sqrt(max(lo, 0.0)), math.sqrt(max(hi, 0.0)))
        return Noise3d(T, V, H, m + (self._offset or 0.0), sigma, corrected, ci, dof)


def noise_3d(cube: np.ndarray, confidence: float = CONFIDENCE) -> Noise3d:
    """The 3D noise of ``cube`` (T, V, H), any numeric dtype (module docstring)."""
    arr = cube if isinstance(cube, np.ndarray) else np.asarray(cube)
    if arr.ndim != 3:
        raise ValueError(f"3D noise needs a cube (frames, rows, columns), got shape {arr.shape}")
    sums = Noise3dSums(arr.shape[1], arr.shape[2])
    sums.add(arr)
    return sums.result(confidence)


def pooled(results: Iterable[Noise3d]) -> dict[str, float]:
    """Root mean square of the bias-corrected figures of several cubes (the mean of their
    variance estimates, square-rooted): one camera's noise over its stops."""
    items = list(results)
    if not items:
        return {k: math.nan for k in FIGURES}
    return {
        k: math.sqrt(sum(r.sigma_corrected[k] ** 2 for r in items) / len(items)) for k in FIGURES
    }
