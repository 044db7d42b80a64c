"""SNR versus range: paper Eqs. 2-3, the four curves of Figs. 7-10 (sections 2, 8), and what
Eq. (4) is expected to read.

Signal (Eq. 2), in photons over the band through tau_optics tau_cold_filter QE(lambda): the
contrast radiance of :mod:`snrmon.model.contrast` (separate sky and air temperatures, the
contrast-weighted transmission) over the target's area A_t at range R gives the point-source
contrast S_pt = A_opt t_int A_t / R^2 integral tau dLq resp (PVF = 1); the pixel's share of it
depends on the geometry:

* ``geometry="square"`` (default, continuous): the target is a square of side D = size / (R
  IFOV) pixels convolved with the PSF and the PVF is its phase-averaged ensquared energy
  (:func:`snrmon.model.footprint.average_pvf_square`) at EVERY range: S_e = S_pt x PVF(D). It is the
  point-source average PVF for D -> 0 and FF / D^2 for D >> 1, where S_e becomes the paper's
  pixel-filling radiance A_opt t_int FF IFOV^2 dLq exactly; in between it has no jump.
* ``geometry="paper"``: the paper's switched curves: resolved (D >= 1) pixel-filling radiance,
  unresolved point source x average PVF, the finite size (corrected curves) as a Gaussian of
  sigma_t = ``target_sigma_per_size`` x D. Its jump at D = 1 (MWIR UAV1 small, 314 m: 389 -> 117
  uncorrected) is the paper's, not physics; these curves are always in ``paper`` too.

Curves: small/large characteristic dimension x uncorrected (diffraction-limited Airy averaged
over the band) / corrected (the sensor's real PSF, or one measured from flight data).
SNR = S_e / sqrt(temporal^2 + spatial^2) (Eq. 3), temporal from Eq. 1 against the sky.

The expected Eq. (4) readings are the mean of what the estimator reads on the corrected small
curve's target (:mod:`snrmon.model.eq4`: peak-search bias, the rim's share of the PSF, the
24-pixel std), one per background rule (:data:`EXPECTED_CURVES`):

* ``expected_eq4_rim``: the paper's Eq. (4), mean and std of the 24 rim pixels of the 7x7 box;
* ``expected_eq4_extent``: the console's target-aware rule, which departs from the paper's rim
  for a drone wider than the box's 5x5 guard (the rim of its extent grown by a 2 px guard,
  weighted by the chance that the extent reaches the 7x7 rim); the two agree on a compact one.

The band (``lower``/``upper``) is the Monte-Carlo band of :mod:`snrmon.model.montecarlo`.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field, fields

import numpy as np
from scipy.interpolate import CubicSpline, PchipInterpolator

from snrmon.model.contrast import contrast
from snrmon.model.eq4 import expected_eq4_by_rule
from snrmon.model.footprint import average_pvf_square
from snrmon.model.montecarlo import InputUncertainty, McDraws, draw_corrected
from snrmon.model.noise import MeasuredNoise, NoiseBreakdown, noise_breakdown
from snrmon.model.psf import Psf
from snrmon.model.pvf import average_pvf, average_pvf_vs_target_sigma
from snrmon.model.sensor import Sensor
from snrmon.model.target import Target
from snrmon.model.uncertainty import UncertaintyBudget

CURVES = ("small", "large", "small_corrected", "large_corrected")
EXPECTED_CURVES = {"expected_eq4_rim": "rim", "expected_eq4_extent": "target"}
"""The expected Eq. (4) readings and the background rule of :func:`snrmon.model.eq4.expected_eq4`
each follows: the paper's 7x7 rim, and the console's target-aware rule (module docstring)."""
CURVE = "curve"
"""The metadata key naming the curve an :class:`SnrPrediction` field holds."""
GEOMETRIES = ("square", "paper")
FOOTPRINTS = ("square", "outline")
"""The small target's footprint with ``geometry="square"``: the paper's square of the small
dimension, or the target's :class:`snrmon.model.target.Outline` (the segmented pixels of a
close stop, scaled by range): the same light (the small dimension's area) spread over the
drone's shape (paper sections 3 and 10)."""
_OUTLINE_NODES = 64  # more ranges than this: the outline's PVF at as many log-spaced sizes
DEFAULT_TARGET_SIGMA_PER_SIZE = 0.5
"""The paper geometry's sigma_t = D / 2 (with the paper's sigma = 0.8 px this
reproduces its relative PVF drop with target size)."""
_EXPECTED_NODES = 28  # up to this many ranges, the expected reading is computed at each
# Above it, at nodes (expected_readings): every NODE_SPACING_FAR in ln(range) where the target
# is compact (the reading is smooth there), every NODE_SPACING_NEAR where it is wider than
# NODE_NEAR_PX (the 7x7 rim then lies on the drone: the paper's rim reading bends with the
# sub-pixel detail of what it sees); then, in up to REFINE_ROUNDS rounds, a node at the middle
# of each interval where the cubic spline and PCHIP through the nodes (two interpolants that
# agree where the nodes resolve the curve) part by more than REFINE_TOL in ln(reading), down
# to intervals of 2 x NODE_SPACING_MIN. The readings are a cubic spline in log-log through
# them; the target rule's, where the drone is wider than STEP_PX, through nodes at least
# STEP_SPACING apart (its steps, _spaced). Held to the direct computation within 0.5 %
# (tests/model/test_expected_nodes.py; docs/model.md).
NODE_SPACING_FAR = 0.5
NODE_SPACING_NEAR = 0.25
NODE_NEAR_PX = 2.0
REFINE_TOL = 2e-3
REFINE_ROUNDS = 5
NODE_SPACING_MIN = 0.05
STEP_SPACING = 0.15
STEP_PX = 4.0
MIN_NODES = 5


@dataclass(frozen=True, eq=False)
class SnrPrediction:
    """The four curves over ``ranges_m`` and what made them. Arrays have one value per range.

    ``signal_e``, ``pvf``, ``paper`` map a curve name (:data:`CURVES`) to arrays; ``pvf`` is
    NaN where the paper geometry calls the target resolved; ``lower``/``upper`` (the band) exist
    for the corrected curves and the expected readings; ``relative_uncertainty`` is the Fig. 12
    budget (deterministic, as the paper tabulates it). ``noise`` is per pixel.
    """

    sensor_name: str
    target_name: str
    atmosphere_name: str
    background_temp_k: float  # the sky (measured or the model's own)
    air_temp_k: float
    geometry: str
    ranges_m: np.ndarray
    # The curves by name (:data:`CURVES`; :meth:`curves` gives them all).
    snr_small: np.ndarray = field(metadata={CURVE: "small"})
    snr_large: np.ndarray = field(metadata={CURVE: "large"})
    snr_small_corrected: np.ndarray = field(metadata={CURVE: "small_corrected"})
    snr_large_corrected: np.ndarray = field(metadata={CURVE: "large_corrected"})
    resolved_small: np.ndarray
    resolved_large: np.ndarray
    signal_e: dict[str, np.ndarray]
    pvf: dict[str, np.ndarray]
    noise: NoiseBreakdown
    transmission: np.ndarray  # flat over the band
    transmission_contrast: np.ndarray  # weighted by a near-ambient target's contrast
    lower: dict[str, np.ndarray]
    upper: dict[str, np.ndarray]
    relative_uncertainty: dict[str, np.ndarray]
    transition_range_small_m: float
    transition_range_large_m: float
    point_contrast_e: dict[str, np.ndarray] = field(default_factory=dict)
    paper: dict[str, np.ndarray] = field(default_factory=dict)
    # the paper's 7x7 rim; the console's target-aware rule (None: not computed)
    expected_eq4_rim: np.ndarray | None = field(default=None, metadata={CURVE: "expected_eq4_rim"})
    expected_eq4_extent: np.ndarray | None = field(
        default=None, metadata={CURVE: "expected_eq4_extent"}
    )
    draws: McDraws | None = None  # the Monte-Carlo draws behind the band
    sky_assumed: bool = False  # no sky temperature given: assumed the air's, the band widened

    def curves(self) -> dict[str, np.ndarray]:
        """Every curve over ``ranges_m`` by name: the four (:data:`CURVES`), the expected Eq. (4)
        readings the prediction has (:data:`EXPECTED_CURVES`), the paper's switched curves
        (``paper_<curve>``) and the band's edges (``<curve>_lower``, ``<curve>_upper``)."""
        out = {
            f.metadata[CURVE]: getattr(self, f.name)
            for f in fields(self)
            if CURVE in f.metadata and getattr(self, f.name) is not None
        }
        out |= {f"paper_{name}": snr for name, snr in self.paper.items()}
        for name in self.lower:  # the Monte-Carlo band of the model's uncertain inputs
            if name in self.upper:
                out[f"{name}_lower"], out[f"{name}_upper"] = self.lower[name], self.upper[name]
        return out

    def snr(self, curve: str) -> np.ndarray:
        """One curve of :data:`CURVES` or :data:`EXPECTED_CURVES` by name."""
        if curve not in CURVES and curve not in EXPECTED_CURVES:
            known = ", ".join((*CURVES, *EXPECTED_CURVES))
            raise ValueError(f"unknown curve {curve!r}; known: {known}")
        value = self.curves().get(curve)
        if value is None:
            raise ValueError("this prediction was made without the expected Eq. (4) curves")
        return value

    @property
    def noise_e(self) -> dict[str, float]:
        return self.noise.as_dict()

    def to_records(self) -> list[dict]:
        """One JSON-ready object per range (the ``snrmon model snr --json`` contract)."""
        out = []
        curves = self.curves()
        for i, r in enumerate(self.ranges_m):
            rec = {
                "range_m": float(r),
                "resolved_small": bool(self.resolved_small[i]),
                "resolved_large": bool(self.resolved_large[i]),
                **{f"snr_{name}": float(curves[name][i]) for name in CURVES},
                **{
                    name: float(curves[name][i]) if name in curves else None
                    for name in EXPECTED_CURVES
                },
                "snr_paper": {c: float(self.paper[c][i]) for c in self.paper},
                "signal_e": {c: float(self.signal_e[c][i]) for c in CURVES},
                "noise_e": self.noise_e,
                "transmission": float(self.transmission[i]),
                "transmission_contrast": float(self.transmission_contrast[i]),
                "air_temp_k": float(self.air_temp_k),
                "sky_temp_k": float(self.background_temp_k),
                "sky_assumed_equal_to_air": bool(self.sky_assumed),
                "pvf": {c: _none_if_nan(self.pvf[c][i]) for c in CURVES},
                "uncertainty": {
                    c: [float(self.lower[c][i]), float(self.upper[c][i])] for c in self.lower
                },
            }
            out.append(rec)
        return out


def _none_if_nan(x: float) -> float | None:
    return None if math.isnan(x) else float(x)


def _check_ranges(ranges_m) -> np.ndarray:
    r = np.atleast_1d(np.asarray(ranges_m, dtype=float))
    if r.ndim != 1 or r.size == 0:
        raise ValueError("ranges must be a non-empty list of numbers")
    bad = ~np.isfinite(r) | (r <= 0)
    if np.any(bad):
        raise ValueError(f"range must be a finite number > 0 m, got {r[bad][0]!r}")
    return r


def transition_range_m(sensor: Sensor, size_m: float) -> float:
    """Range at which a target of characteristic dimension ``size_m`` equals the pixel
    footprint (D = 1 px: the paper's resolved/unresolved switch): size / IFOV."""
    return float(size_m) / sensor.ifov_rad


def target_contrast_electrons(
    sensor: Sensor,
    target: Target,
    range_m: float,
    *,
    size: str = "small",
    atmosphere=None,
    background_temp_k: float | None = None,
    air_temp_k: float | None = None,
) -> float:
    """Contrast electrons per frame that the whole target puts on the focal plane (point-source
    equivalent, PVF = 1, no fill factor): A_opt t_int A_t / R^2 integral dLq resp dlambda with
    the contrast of :mod:`snrmon.model.contrast`. Spread it with :mod:`snrmon.model.footprint` to
    get pixels."""
    r = _check_ranges(range_m)
    c = contrast(
        sensor,
        target,
        r,
        atmosphere=atmosphere,
        sky_temp_k=background_temp_k,
        air_temp_k=air_temp_k,
    )
    return float(c.intensity_e()[0] * target.area_m2(size) / r[0] ** 2)


def _paper_pvf(psf, ff, d_px, resolved, sigma_per_size, point: bool) -> np.ndarray:
    if point:
        return np.full(d_px.shape, average_pvf(psf, ff))
    return average_pvf_vs_target_sigma(psf, ff, np.where(resolved, 0.0, sigma_per_size * d_px))


def expected_reading(
    psf: Psf,
    fill_factor: float,
    ranges_m: np.ndarray,
    amplitude: np.ndarray,
    d_px: np.ndarray,
    *,
    geometry: str = "square",
    target_sigma_per_size: float = DEFAULT_TARGET_SIGMA_PER_SIZE,
    nodes: int = _EXPECTED_NODES,
    phases_xy=None,
    background: str = "target",
) -> np.ndarray:
    """:func:`snrmon.model.eq4.expected_eq4` along a range grid (amplitude = point contrast / noise,
    d_px the target's side in pixels): computed at every range of a grid of up to ``nodes``
    ranges; on a longer one at nodes placed and refined along it and interpolated between
    them (:data:`_EXPECTED_NODES`; within 0.5 % of the reading computed at every range).
    ``phases_xy``: over these observed sub-pixel phases instead of the whole cell;
    ``background``: "rim" (the paper's 7x7 rim) or "target" (the console's rule), see
    :data:`EXPECTED_CURVES`."""
    return expected_readings(
        psf,
        fill_factor,
        ranges_m,
        amplitude,
        d_px,
        geometry=geometry,
        target_sigma_per_size=target_sigma_per_size,
        nodes=nodes,
        phases_xy=phases_xy,
        backgrounds=(background,),
    )[background]


def expected_readings(
    psf: Psf,
    fill_factor: float,
    ranges_m: np.ndarray,
    amplitude: np.ndarray,
    d_px: np.ndarray,
    *,
    geometry: str = "square",
    target_sigma_per_size: float = DEFAULT_TARGET_SIGMA_PER_SIZE,
    nodes: int = _EXPECTED_NODES,
    phases_xy=None,
    backgrounds: tuple[str, ...] = ("rim", "target"),
) -> dict[str, np.ndarray]:
    """:func:`expected_reading` of several background rules at once (one pattern and peak
    computation per node): ``{rule: readings}``. The nodes depend on the inputs alone (not on
    what was computed before); their patterns are kept (:func:`snrmon.model.eq4.phase_patterns`),
    so a new sky on a known grid reads the patterns already computed for most of them."""
    r = np.asarray(ranges_m, float)

    def at(idx):
        kw = (
            {"target_square_px": d_px[idx]}
            if geometry == "square"
            else {"target_sigma_px": target_sigma_per_size * d_px[idx]}
        )
        # A target no brighter than its background (the contrast can cross zero at long range
        # where a warm sky's path radiance catches up) gives Eq. (4) no peak of its own: the
        # estimator reads the noise, as for a zero contrast.
        amp = np.clip(amplitude[idx], 0.0, None)
        return expected_eq4_by_rule(
            psf, fill_factor, amp, backgrounds=backgrounds, phases_xy=phases_xy, **kw
        )

    if r.size <= nodes:
        return at(np.arange(r.size))
    # on the distinct ranges, ascending (a range given twice reads the same)
    r_u, first, back = np.unique(r, return_index=True, return_inverse=True)
    lr = np.log(r_u)
    d_u = np.asarray(d_px, float)[first]
    picked = _first_nodes(lr.tobytes(), d_u.tobytes())
    values = {rule: np.log(v) for rule, v in at(first[picked]).items()}
    for _ in range(REFINE_ROUNDS):
        more = _refinements(lr, picked, values)
        if more.size == 0:
            break
        new = {rule: np.log(v) for rule, v in at(first[more]).items()}
        picked = np.concatenate([picked, more])
        order = np.argsort(picked)
        picked = picked[order]
        values = {rule: np.concatenate([values[rule], new[rule]])[order] for rule in values}
    out = {}
    for rule, v in values.items():
        keep = _spaced(lr[picked], d_u[picked] > STEP_PX) if rule == "target" else slice(None)
        out[rule] = np.exp(CubicSpline(lr[picked][keep], v[keep])(lr))[back.ravel()]
    return out


def _spaced(x: np.ndarray, wide: np.ndarray) -> np.ndarray:
    """Indices of ascending ``x``: all where not ``wide``, else at least :data:`STEP_SPACING`
    apart; both ends kept. Where the drone is wide, the target rule's reading steps by up to
    0.4 % at the ranges where a pixel joins its 3-sigma extent (the background rim moves out
    by a pixel): its spline steps over them, as the console's readings, noisy frame by frame,
    do (the curve stays free of jumps, tests/model/test_continuous.py)."""
    keep = [0]
    for i in range(1, x.size - 1):
        if not (wide[i] or wide[keep[-1]]) or x[i] - x[keep[-1]] >= STEP_SPACING:
            keep.append(i)
    if wide[-1] and x[-1] - x[keep[-1]] < 0.5 * STEP_SPACING and len(keep) > 1:
        keep.pop()
    keep.append(x.size - 1)
    return np.array(keep)


def clear_caches() -> None:
    """Forget what the model keeps between predictions (the PSFs' frequency grids and PVF
    tables, the quadrature nodes, the path's transmission, the expected reading's patterns,
    nodes and readings, the band's sky-free draws): the next prediction computes everything
    again, as a fresh process would."""
    from snrmon.model import contrast, eq4, footprint, montecarlo, pvf, quadrature

    eq4._READINGS.clear()
    montecarlo._AREA_PVF.clear()
    contrast._TAU.clear()
    montecarlo._THROUGH.clear()
    for cached in (
        _first_nodes,
        eq4.phase_patterns,
        montecarlo.widened_psf,
        footprint.otf_grid,
        footprint._square_table,
        footprint._square_table_chunk,
        footprint._pattern_weights,
        pvf._polar_weights,
        pvf._pvf_table,
        quadrature.gauss_legendre,
    ):
        cached.cache_clear()


@functools.lru_cache(maxsize=16)
def _first_nodes(log_ranges: bytes, d_px: bytes) -> np.ndarray:
    """:func:`expected_nodes`, kept per range grid and target (a new sky reads the same)."""
    picked = expected_nodes(np.frombuffer(log_ranges), np.frombuffer(d_px))
    picked.setflags(write=False)
    return picked


def expected_nodes(log_ranges: np.ndarray, d_px: np.ndarray) -> np.ndarray:
    """The first nodes of the expected reading (indices into ``log_ranges``, ascending and
    distinct): both ends and steps of :data:`NODE_SPACING_FAR` in ln(range), or
    :data:`NODE_SPACING_NEAR` where the target is wider than :data:`NODE_NEAR_PX`."""
    picks = [0]
    last = log_ranges.size - 1
    for i in range(1, last):
        wide = max(d_px[i], d_px[picks[-1]]) > NODE_NEAR_PX
        step = NODE_SPACING_NEAR if wide else NODE_SPACING_FAR
        if log_ranges[i] - log_ranges[picks[-1]] >= step:
            picks.append(i)
    if last - picks[-1] == 1 and len(picks) > 1 and last > 2:
        picks[-1] = last  # no interval of one step at the end
    elif picks[-1] != last:
        picks.append(last)
    if len(picks) < MIN_NODES:  # a short span of ranges: a few nodes across it
        return np.unique(np.round(np.linspace(0, last, MIN_NODES)).astype(int))
    return np.array(picks)


def _refinements(
    log_ranges: np.ndarray, picked: np.ndarray, values: dict[str, np.ndarray]
) -> np.ndarray:
    """The ranges (indices) nearest the middle of each interval between nodes where the cubic
    spline and PCHIP through the nodes part by more than :data:`REFINE_TOL` (two
    interpolants of the same nodes that agree where the nodes resolve the curve)."""
    x = log_ranges[picked]
    v = np.stack(list(values.values()), axis=1)  # every rule in one interpolant
    spline, pchip = CubicSpline(x, v)(log_ranges), PchipInterpolator(x, v)(log_ranges)
    gap = np.abs(spline - pchip).max(axis=1)
    lo, hi = picked[:-1], picked[1:]
    inner = (hi - lo >= 2) & (log_ranges[hi] - log_ranges[lo] >= 2.0 * NODE_SPACING_MIN)
    worst = np.maximum.reduceat(gap, lo)  # each interval's worst, nodes included (gap 0)
    flagged = inner & (worst > REFINE_TOL)
    # a cubic's error falls as the fourth power of the spacing: split an interval into as many
    # as bring its gap under the tolerance (fewer rounds), no part under NODE_SPACING_MIN
    width = (log_ranges[hi] - log_ranges[lo])[flagged]
    parts = np.ceil((worst[flagged] / REFINE_TOL) ** 0.25)
    parts = np.clip(parts, 2, np.maximum(2, np.floor(width / NODE_SPACING_MIN)))
    # the ranges nearest the points k / parts of the way along each interval, 0 < k < parts
    # (the arithmetic of np.linspace)
    inside = parts.astype(int) - 1
    a, b = np.repeat(lo[flagged], inside), np.repeat(hi[flagged], inside)
    k = np.arange(a.size) - np.repeat(np.cumsum(inside) - inside, inside) + 1.0
    at = k * ((log_ranges[b] - log_ranges[a]) / np.repeat(parts, inside)) + log_ranges[a]
    j = np.searchsorted(log_ranges, at)
    j = np.where(np.abs(log_ranges[j - 1] - at) <= np.abs(log_ranges[j] - at), j - 1, j)
    return np.unique(np.clip(j, a + 1, b - 1))


def predict(
    sensor: Sensor,
    target: Target,
    ranges_m,
    *,
    atmosphere=None,
    background_temp_k: float | None = None,
    air_temp_k: float | None = None,
    spatial_noise: float | str | None = None,
    measured_noise: MeasuredNoise | None = None,
    corrected_psf: Psf | None = None,
    geometry: str = "square",
    target_sigma_per_size: float = DEFAULT_TARGET_SIGMA_PER_SIZE,
    uncertainty: UncertaintyBudget | None = None,
    inputs: InputUncertainty | None = None,
    expected: bool = True,
    band: bool = True,
    phases_xy=None,
    footprint: str = "square",
) -> SnrPrediction:
    """The four SNR curves of Figs. 7-10 at ``ranges_m`` (metres, > 0); see the module
    docstring.

    ``atmosphere``: None or "default" (built-in US Std 1976 power law), "none", a number (constant
    transmission), an :class:`Atmosphere` or a file path. ``background_temp_k``: the measured sky
    temperature (the paper's path-radiance correction); ``air_temp_k``: the air along the path
    (default the atmosphere's). ``spatial_noise``: see :func:`snrmon.model.noise.spatial_noise_e`.
    ``measured_noise``: the camera's measured 3D noise in place of Eq. 1 and the spatial term
    (:class:`snrmon.model.noise.MeasuredNoise`; the operator's "measured noise").
    ``corrected_psf``: the real PSF (default the sensor's). ``expected``: compute the expected
    Eq. (4) readings of both background rules (:data:`EXPECTED_CURVES`), over the sub-pixel
    phases ``phases_xy`` (N, 2) that a stop's frames sampled if given
    (:func:`snrmon.model.eq4.expected_eq4`), else over the whole cell; ``band``:
    the Monte-Carlo band (``inputs``, default :class:`snrmon.model.montecarlo.InputUncertainty`).
    ``footprint`` (:data:`FOOTPRINTS`): the small curves' target, the paper's square or the
    target's outline (the expected readings and the band keep the square).
    """
    ranges = _check_ranges(ranges_m)
    shape = (geometry, target_sigma_per_size, footprint)  # how the target lies on the pixels
    _check_shape(target, *shape)
    c = contrast(
        sensor,
        target,
        ranges,
        atmosphere=atmosphere,
        sky_temp_k=background_temp_k,
        air_temp_k=air_temp_k,
    )
    noise = noise_breakdown(sensor, c.sky_temp_k, spatial_noise, measured_noise)
    real = corrected_psf if corrected_psf is not None else sensor.corrected_psf()
    curves = _size_curves(sensor, target, c, noise.total, real, *shape)
    rel = _relative_uncertainties(c, uncertainty or UncertaintyBudget(), curves.resolved)
    expected_curves: dict[str, np.ndarray] = {}
    if expected:
        expected_curves = _expected_curves(
            real, sensor.fill_factor, curves, geometry, target_sigma_per_size, phases_xy
        )
    draws = None
    lower: dict[str, np.ndarray] = {}
    upper: dict[str, np.ndarray] = {}
    if band:
        sizes_m = {s: target.size_m(s) for s in ("small", "large")}
        draws = draw_corrected(
            sensor, c, sizes_m, real, spatial_noise, inputs or InputUncertainty(), measured_noise
        )
        lower, upper = _band_limits(draws, curves.snr, expected_curves)
    return SnrPrediction(
        sensor_name=sensor.name,
        target_name=target.name,
        atmosphere_name=c.atmosphere.name,
        background_temp_k=c.sky_temp_k,
        air_temp_k=c.air_temp_k,
        geometry=geometry,
        ranges_m=ranges,
        snr_small=curves.snr["small"],
        snr_large=curves.snr["large"],
        snr_small_corrected=curves.snr["small_corrected"],
        snr_large_corrected=curves.snr["large_corrected"],
        resolved_small=curves.resolved["small"],
        resolved_large=curves.resolved["large"],
        signal_e=curves.signal_e,
        pvf=curves.pvf,
        noise=noise,
        transmission=c.transmission_flat,
        transmission_contrast=c.transmission_contrast,
        lower=lower,
        upper=upper,
        relative_uncertainty=rel,
        transition_range_small_m=transition_range_m(sensor, target.small_m),
        transition_range_large_m=transition_range_m(sensor, target.large_m),
        point_contrast_e=curves.point,
        paper=curves.paper,
        expected_eq4_rim=expected_curves.get("expected_eq4_rim"),
        expected_eq4_extent=expected_curves.get("expected_eq4_extent"),
        draws=draws,
        sky_assumed=c.sky_assumed,
    )


@dataclass(frozen=True)
class _SizeCurves:
    """Per curve (:data:`CURVES`): the Eq. (3) SNR, the peak pixel's signal [e-], its PVF and
    the paper's own SNR; per size ("small", "large"): resolved or not, the point-source
    contrast [e-] before the PVF, and the target's size in pixels; at ``ranges_m``, against
    the total noise ``noise_e`` [e-]."""

    snr: dict[str, np.ndarray]
    signal_e: dict[str, np.ndarray]
    pvf: dict[str, np.ndarray]
    paper: dict[str, np.ndarray]
    resolved: dict[str, np.ndarray]
    point: dict[str, np.ndarray]
    d_px: dict[str, np.ndarray]
    ranges_m: np.ndarray
    noise_e: float


def _size_curves(
    sensor: Sensor,
    target: Target,
    c,
    denom: float,
    real: Psf,
    geometry: str,
    sigma_per_size: float,
    footprint: str = "square",
) -> _SizeCurves:
    """The four curves of Figs. 7-10 (each size with the diffraction PSF and with ``real``)
    over the contrast ``c``'s ranges, against the total noise ``denom`` [e-] (Eq. 3); the
    small ones over the target's outline with ``footprint="outline"``."""
    ranges = c.ranges_m
    intensity = c.intensity_e()
    ff = sensor.fill_factor
    ext = intensity * ff * sensor.ifov_rad**2
    diffraction = sensor.diffraction_psf()
    footprint_m = ranges * sensor.ifov_rad
    out = _SizeCurves({}, {}, {}, {}, {}, {}, {}, ranges, denom)
    for size in ("small", "large"):
        d_px = target.size_m(size) / footprint_m
        res = d_px >= 1.0
        out.resolved[size], out.d_px[size] = res, d_px
        out.point[size] = intensity * target.area_m2(size) / ranges**2
        for curve, psf, corrected in (
            (size, diffraction, False),
            (f"{size}_corrected", real, True),
        ):
            # the paper corrects for the finite size on the corrected curves of both cameras,
            # whatever their PSF (the LWIR's "real" PSF may be the diffraction limit itself)
            paper_pvf = _paper_pvf(psf, ff, d_px, res, sigma_per_size, not corrected)
            paper_sig = np.where(res, ext, out.point[size] * paper_pvf)
            out.paper[curve] = paper_sig / denom
            if geometry == "square" and size == "small" and footprint == "outline":
                pvf = outline_pvf(psf, ff, target, footprint_m=footprint_m)
                sig = out.point[size] * pvf
            elif geometry == "square":
                pvf = np.asarray(average_pvf_square(psf, ff, d_px), float)
                sig = out.point[size] * pvf
            else:
                pvf, sig = np.where(res, np.nan, paper_pvf), paper_sig
            out.signal_e[curve], out.pvf[curve] = sig, pvf
            out.snr[curve] = sig / denom
    return out


def outline_pvf(psf: Psf, fill_factor: float, target: Target, *, footprint_m) -> np.ndarray:
    """The average PVF of ``target``'s outline (:func:`snrmon.model.footprint.
    average_pvf_outline`) at each range's pixel footprint ``footprint_m`` (range x IFOV, m):
    the outline's shape at the small dimension's area (the paper's small dimension is the
    square root of the outlined area, section 3: an outline segmented wider, by the PSF's blur
    at its edges, is scaled to the target's area), each of its pixels a square of its scaled
    ``pixel_m`` over the footprint. Over more than :data:`_OUTLINE_NODES` ranges, at that many
    log-spaced footprints and interpolated (PCHIP in ln footprint of PVF (1 + D^2) / FF, D the
    small dimension in pixels, smooth and O(1) as the square's table)."""
    from snrmon.model.footprint import average_pvf_outline

    outline = target.outline
    assert outline is not None  # _check_shape
    f_m = np.asarray(footprint_m, float)
    side_m = float(target.small_m)
    cell_m = outline.pixel_m * side_m / math.sqrt(outline.area_m2)
    if f_m.size <= _OUTLINE_NODES:
        return np.asarray(average_pvf_outline(psf, fill_factor, outline, cell_m / f_m))
    nodes = np.geomspace(f_m.min(), f_m.max(), _OUTLINE_NODES)
    d = side_m / nodes
    h = average_pvf_outline(psf, fill_factor, outline, cell_m / nodes) * (1 + d * d)
    d_all = side_m / f_m
    return (
        fill_factor
        * PchipInterpolator(np.log(nodes), h / fill_factor)(np.log(f_m))
        / (1 + d_all * d_all)
    )


def _check_shape(target: Target, geometry: str, sigma_per_size: float, footprint: str) -> None:
    _check_geometry(geometry, sigma_per_size)
    if footprint not in FOOTPRINTS:
        raise ValueError(f"footprint must be one of {', '.join(FOOTPRINTS)}, got {footprint!r}")
    if footprint == "outline" and target.outline is None:
        raise ValueError(
            f"target {target.name!r} has no outline for footprint outline: characterize a "
            "close stop (snrmon characterize --target-out) and use that target file"
        )
    if footprint == "outline" and geometry != "square":
        raise ValueError("footprint outline is a continuous geometry: use geometry square")


def _check_geometry(geometry: str, target_sigma_per_size: float) -> None:
    if geometry not in GEOMETRIES:
        raise ValueError(f"geometry must be one of {', '.join(GEOMETRIES)}, got {geometry!r}")
    if not (target_sigma_per_size >= 0 and math.isfinite(target_sigma_per_size)):
        raise ValueError(f"target_sigma_per_size must be >= 0, got {target_sigma_per_size!r}")


def _expected_curves(
    real: Psf,
    ff: float,
    curves: _SizeCurves,
    geometry: str,
    target_sigma_per_size: float,
    phases_xy,
) -> dict[str, np.ndarray]:
    """The expected Eq. (4) readings of the small target at the ranges of ``curves``, one per
    rule of :data:`EXPECTED_CURVES`."""
    by_rule = expected_readings(
        real,
        ff,
        curves.ranges_m,
        curves.point["small"] / curves.noise_e,
        curves.d_px["small"],
        geometry=geometry,
        target_sigma_per_size=target_sigma_per_size,
        phases_xy=phases_xy,
        backgrounds=tuple(EXPECTED_CURVES.values()),
    )
    return {name: by_rule[rule] for name, rule in EXPECTED_CURVES.items()}


def _relative_uncertainties(
    c, budget: UncertaintyBudget, resolved: dict[str, np.ndarray]
) -> dict[str, np.ndarray]:
    """The corrected curves' relative 1-sigma uncertainty from ``budget``, per range."""
    amp = c.background_over_contrast
    od = -np.log(np.clip(c.transmission_contrast, 1e-300, 1.0))
    sky_per_k = _sky_fraction_per_k(c) if c.sky_assumed else None
    return {
        f"{size}_corrected": budget.relative(amp, ~resolved[size], od, sky_per_k)
        for size in ("small", "large")
    }


def _band_limits(
    draws: McDraws, snr: dict[str, np.ndarray], expected_curves: dict[str, np.ndarray]
) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray]]:
    """(lower, upper): the Monte-Carlo band of the corrected curves and of the expected
    readings, scaled onto the curves as computed."""
    lower, upper = {}, {}
    for name in ("small_corrected", "large_corrected"):
        lo, hi = draws.band(name)
        # the draws are of the square geometry: as relative spreads about their own nominal
        # curve they carry over to the paper's
        scale = snr[name] / draws.nominal[name]
        lower[name], upper[name] = lo * scale, hi * scale
    for name, reading in expected_curves.items():
        ratio = reading / snr["small_corrected"]
        lower[name] = lower["small_corrected"] * ratio
        upper[name] = upper["small_corrected"] * ratio
    return lower, upper


def _sky_fraction_per_k(c) -> float:
    """(dL_sky/dT) / L_sky over the response [1/K]: a sky temperature error as a fraction of
    its radiance."""
    from snrmon.model.radiometry import spectral_photon_radiance, spectral_photon_radiance_dt

    wl = c.wavelengths_um
    l_sky = float(np.sum(c.k_spec * spectral_photon_radiance(wl, c.sky_temp_k)))
    return float(np.sum(c.k_spec * spectral_photon_radiance_dt(wl, c.sky_temp_k))) / l_sky


def detection_range_m(
    sensor: Sensor,
    target: Target,
    snr_threshold: float,
    *,
    curve: str = "small_corrected",
    max_range_m: float = 20000.0,
    **predict_kwargs,
) -> float:
    """Farthest range [m] at which ``curve``'s SNR still reaches ``snr_threshold`` (searched
    from 1 m to ``max_range_m`` and refined by bisection). 0.0 if it never does; ``max_range_m``
    if it still does there."""
    if not (snr_threshold > 0 and math.isfinite(snr_threshold)):
        raise ValueError(f"SNR threshold must be > 0, got {snr_threshold!r}")
    if curve not in CURVES:
        raise ValueError(f"unknown curve {curve!r}; known: {', '.join(CURVES)}")
    kw = {"expected": False, "band": False, **predict_kwargs}
    grid = np.geomspace(1.0, max_range_m, 2000)
    snr = predict(sensor, target, grid, **kw).snr(curve)
    above = np.nonzero(snr >= snr_threshold)[0]
    if above.size == 0:
        return 0.0
    i = int(above[-1])
    if i == grid.size - 1:
        return float(max_range_m)
    lo, hi = grid[i], grid[i + 1]
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if predict(sensor, target, [mid], **kw).snr(curve)[0] >= snr_threshold:
            lo = mid
        else:
            hi = mid
    return float(lo)
