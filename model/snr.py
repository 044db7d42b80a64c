"""SNR versus range: paper Eqs. 2-3 with the resolved/unresolved rule and the four curves of
Figs. 7-10 (sections 2, 8).

Signal (Eq. 2), in photons integrated over the band with tau_optics tau_cold_filter QE(lambda):

* contrast photon radiance dLq(R, lambda) = tau(R) L_t + L_path(R) - L_bg. The path radiance is
  (1 - tau) S(lambda) and the clear-sky background is the infinite path, L_bg = S; S is a
  blackbody at the measured background temperature when one is given (the paper's correction),
  else at the atmosphere's air temperature (or MODTRAN's path source). Hence dLq = tau (L_t - S).
* unresolved (characteristic dimension < pixel footprint R IFOV): point-source intensity
  dLq A_t over R^2 into A_opt, times the average PVF: S_e = A_opt t_int PVF dLq A_t / R^2;
* resolved: pixel-filling radiance over the detector's solid angle, S_e = A_opt t_int FF IFOV^2
  dLq (no PVF; the paper applies no correction to resolved ranges).

Curves: small/large characteristic dimension x uncorrected (diffraction-limited Airy averaged
over the band, point target) / corrected (the sensor's real PSF, and a finite Gaussian target of
sigma_t = ``target_sigma_per_size`` x D, D the dimension in pixels, convolved with it).
SNR = S_e / sqrt(temporal^2 + spatial^2) (Eq. 3); temporal from Eq. 1 against the background.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from model.atmosphere import Atmosphere, band_key, resolve_atmosphere
from model.detector import spectral_grid
from model.noise import NoiseBreakdown, noise_breakdown
from model.psf import Psf
from model.pvf import average_pvf, average_pvf_vs_target_sigma
from model.radiometry import spectral_photon_radiance
from model.sensor import Sensor
from model.target import Target
from model.uncertainty import UncertaintyBudget

CURVES = ("small", "large", "small_corrected", "large_corrected")
DEFAULT_TARGET_SIGMA_PER_SIZE = 0.5
"""sigma_t = D / 2 (physics.md: with the paper's sigma = 0.8 px this reproduces its relative
PVF drop with target size)."""


@dataclass(frozen=True, eq=False)
class SnrPrediction:
    """The four curves over ``ranges_m`` and what made them. Arrays have one value per range.

    ``signal_e``, ``pvf``, ``lower``/``upper`` map a curve name (:data:`CURVES`) to arrays;
    ``pvf`` is NaN where that curve's target is resolved; ``lower``/``upper`` (the Fig. 12 band)
    exist for the corrected curves. ``noise`` is per pixel and the same at every range.
    """

    sensor_name: str
    target_name: str
    atmosphere_name: str
    background_temp_k: float
    ranges_m: np.ndarray
    snr_small: np.ndarray
    snr_large: np.ndarray
    snr_small_corrected: np.ndarray
    snr_large_corrected: np.ndarray
    resolved_small: np.ndarray
    resolved_large: np.ndarray
    signal_e: dict[str, np.ndarray]
    pvf: dict[str, np.ndarray]
    noise: NoiseBreakdown
    transmission: np.ndarray
    lower: dict[str, np.ndarray]
    upper: dict[str, np.ndarray]
    relative_uncertainty: dict[str, np.ndarray]
    transition_range_small_m: float
    transition_range_large_m: float
    point_contrast_e: dict[str, np.ndarray] = field(default_factory=dict)

    def snr(self, curve: str) -> np.ndarray:
        if curve not in CURVES:
            raise ValueError(f"unknown curve {curve!r}; known: {', '.join(CURVES)}")
        return getattr(self, f"snr_{curve}")

    @property
    def noise_e(self) -> dict[str, float]:
        return self.noise.as_dict()

    def to_records(self) -> list[dict]:
        """One JSON-ready object per range (the ``snrmon model snr --json`` contract)."""
        out = []
        for i, r in enumerate(self.ranges_m):
            out.append(
                {
                    "range_m": float(r),
                    "resolved_small": bool(self.resolved_small[i]),
                    "resolved_large": bool(self.resolved_large[i]),
                    "snr_small": float(self.snr_small[i]),
                    "snr_large": float(self.snr_large[i]),
                    "snr_small_corrected": float(self.snr_small_corrected[i]),
                    "snr_large_corrected": float(self.snr_large_corrected[i]),
                    "signal_e": {c: float(self.signal_e[c][i]) for c in CURVES},
                    "noise_e": self.noise_e,
                    "transmission": float(self.transmission[i]),
                    "pvf": {c: _none_if_nan(self.pvf[c][i]) for c in CURVES},
                    "uncertainty": {
                        c: [float(self.lower[c][i]), float(self.upper[c][i])] for c in self.lower
                    },
                }
            )
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


@dataclass(frozen=True)
class _Contrast:
    atmosphere: Atmosphere
    background_temp_k: float
    tau: np.ndarray  # (n_ranges, n_wl)
    k_spec: np.ndarray  # A_opt t_int w resp per wavelength [m^2 s um]
    diff: np.ndarray  # L_t - S per wavelength (photon, per um)
    source: np.ndarray  # S per wavelength

    @property
    def intensity_e(self) -> np.ndarray:
        """Electrons per (m^2 of target / m^2 of range^2): A_opt t_int integral tau dLq resp."""
        return self.tau @ (self.k_spec * self.diff)

    @property
    def background_over_contrast(self) -> np.ndarray:
        return (self.tau @ (self.k_spec * self.source)) / (self.tau @ (self.k_spec * self.diff))


def _contrast(
    sensor: Sensor, target: Target, ranges: np.ndarray, atmosphere, background_temp_k
) -> _Contrast:
    atm = resolve_atmosphere(atmosphere, tuple(sensor.band_um))
    wl, w, resp = spectral_grid(sensor)
    t_target = target.temp_k(band_key(sensor.band_um))
    if background_temp_k is not None:
        if not (background_temp_k > 0 and math.isfinite(background_temp_k)):
            raise ValueError(f"background temperature must be > 0 K, got {background_temp_k!r}")
        t_bg = float(background_temp_k)
        source = spectral_photon_radiance(wl, t_bg)
    elif atm.spectral is not None and atm.spectral.has_radiance:
        t_bg = atm.air_temp_k
        source = atm.spectral.path_source_photon(wl)
    else:
        t_bg = atm.air_temp_k
        source = spectral_photon_radiance(wl, t_bg)
    tau = atm.spectral_transmission(ranges, wl)
    k_spec = sensor.aperture_area_m2 * sensor.t_int_s * w * resp
    diff = spectral_photon_radiance(wl, t_target) - source
    return _Contrast(atm, t_bg, tau, k_spec, diff, source)


def transition_range_m(sensor: Sensor, size_m: float) -> float:
    """Range at which a target of characteristic dimension ``size_m`` equals the pixel
    footprint (resolved below it, unresolved beyond): size / IFOV."""
    return float(size_m) / sensor.ifov_rad


def target_contrast_electrons(
    sensor: Sensor,
    target: Target,
    range_m: float,
    *,
    size: str = "small",
    atmosphere=None,
    background_temp_k: float | None = None,
) -> float:
    """Contrast electrons per frame that the whole target puts on the focal plane (point-source
    equivalent, PVF = 1, no fill factor): A_opt t_int A_t / R^2 integral tau dLq resp dlambda.
    Spread it with :func:`model.pvf.pixel_energy_fractions` to get pixel values."""
    r = _check_ranges(range_m)
    c = _contrast(sensor, target, r, atmosphere, background_temp_k)
    return float(c.intensity_e[0] * target.area_m2(size) / r[0] ** 2)


def predict(
    sensor: Sensor,
    target: Target,
    ranges_m,
    *,
    atmosphere=None,
    background_temp_k: float | None = None,
    spatial_noise: float | str | None = None,
    corrected_psf: Psf | None = None,
    target_sigma_per_size: float = DEFAULT_TARGET_SIGMA_PER_SIZE,
    uncertainty: UncertaintyBudget | None = None,
) -> SnrPrediction:
    """The four SNR curves of Figs. 7-10 at ``ranges_m`` (metres, > 0).

    ``atmosphere``: None or "default" (built-in US Std 1976 power law), "none", a number (constant
    transmission), an :class:`Atmosphere` or a file path. ``background_temp_k``: measured sky
    temperature (the paper's path-radiance correction). ``spatial_noise``: see
    :func:`model.noise.spatial_noise_e`. ``corrected_psf``: the real PSF (default the sensor's).
    """
    ranges = _check_ranges(ranges_m)
    if not (target_sigma_per_size >= 0 and math.isfinite(target_sigma_per_size)):
        raise ValueError(f"target_sigma_per_size must be >= 0, got {target_sigma_per_size!r}")
    budget = uncertainty or UncertaintyBudget()
    c = _contrast(sensor, target, ranges, atmosphere, background_temp_k)
    noise = noise_breakdown(sensor, c.background_temp_k, spatial_noise)
    denom = noise.total
    intensity = c.intensity_e
    ext = intensity * sensor.fill_factor * sensor.ifov_rad**2
    ff = sensor.fill_factor
    pvf_point = average_pvf(sensor.diffraction_psf(), ff)
    real = corrected_psf if corrected_psf is not None else sensor.corrected_psf()
    footprint = ranges * sensor.ifov_rad
    amp = c.background_over_contrast
    out: dict[str, dict[str, np.ndarray]] = {"snr": {}, "sig": {}, "pvf": {}, "pt": {}}
    lower, upper, rel = {}, {}, {}
    resolved = {}
    for size in ("small", "large"):
        area = target.area_m2(size)
        res = target.size_m(size) >= footprint
        resolved[size] = res
        point_e = intensity * area / ranges**2
        d_px = target.size_m(size) / footprint
        pvf_c = average_pvf_vs_target_sigma(
            real, ff, np.where(res, 0.0, target_sigma_per_size * d_px)
        )
        for curve, pvf in ((size, np.full(ranges.shape, pvf_point)), (f"{size}_corrected", pvf_c)):
            sig = np.where(res, ext, point_e * pvf)
            out["sig"][curve] = sig
            out["pvf"][curve] = np.where(res, np.nan, pvf)
            out["snr"][curve] = sig / denom
            out["pt"][curve] = point_e
        u = budget.relative(amp, ~res)
        rel[f"{size}_corrected"] = u
        lower[f"{size}_corrected"], upper[f"{size}_corrected"] = budget.band(
            out["snr"][f"{size}_corrected"], u
        )
    wl_w = spectral_grid(sensor)[1]
    return SnrPrediction(
        sensor_name=sensor.name,
        target_name=target.name,
        atmosphere_name=c.atmosphere.name,
        background_temp_k=c.background_temp_k,
        ranges_m=ranges,
        snr_small=out["snr"]["small"],
        snr_large=out["snr"]["large"],
        snr_small_corrected=out["snr"]["small_corrected"],
        snr_large_corrected=out["snr"]["large_corrected"],
        resolved_small=resolved["small"],
        resolved_large=resolved["large"],
        signal_e=out["sig"],
        pvf=out["pvf"],
        noise=noise,
        transmission=c.tau @ wl_w / np.sum(wl_w),
        lower=lower,
        upper=upper,
        relative_uncertainty=rel,
        transition_range_small_m=transition_range_m(sensor, target.small_m),
        transition_range_large_m=transition_range_m(sensor, target.large_m),
        point_contrast_e={s: out["pt"][s] for s in ("small", "large")},
    )


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
    grid = np.geomspace(1.0, max_range_m, 2000)
    snr = predict(sensor, target, grid, **predict_kwargs).snr(curve)
    above = np.nonzero(snr >= snr_threshold)[0]
    if above.size == 0:
        return 0.0
    i = int(above[-1])
    if i == grid.size - 1:
        return float(max_range_m)
    lo, hi = grid[i], grid[i + 1]
    for _ in range(40):
        mid = 0.5 * (lo + hi)
        if predict(sensor, target, [mid], **predict_kwargs).snr(curve)[0] >= snr_threshold:
            lo = mid
        else:
            hi = mid
    return float(lo)
