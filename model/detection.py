"""Probability of detection versus range and the detection range (beyond the paper).

A detector thresholds every pixel of the search area at k noise sigmas above the background;
k is set by the false-alarm rate: ``false_alarms_per_hour`` over ``n_pixels`` pixels at the
camera's frame rate gives a per-pixel probability p = P_fa / n_pixels per frame and
k = Phi^-1(1 - p) (white Gaussian temporal noise, the paper's Eq. 3 without spatial noise).
The target is detected in a frame when any of its pixels exceeds k. With pixel means a_i (the
model's signal spread over the pixels, in sigmas) at a sub-pixel phase,

    Pd(phase) = 1 - prod_i Phi(k - a_i)

and Pd(R) is its mean over phases uniform in the cell: the PVF's phase distribution, not its
average alone (a point that lands on a pixel corner is detected later). The target is the
corrected small curve's (the real PSF, a square of the small dimension). The detection range is
where Pd falls through ``pd_goal``; its confidence comes from the Monte-Carlo draws of the
model's inputs (:mod:`snrmon.model.montecarlo`): the draws scale the pixel means, each draw gives a
detection range, and the 16th-84th percentiles bound it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ndtr, ndtri

from snrmon.model.footprint import phase_grid, pixel_patterns
from snrmon.model.sensor import Sensor
from snrmon.model.snr import predict
from snrmon.model.target import Target


@dataclass(frozen=True)
class Detection:
    """Pd versus range (nominal and the band of the draws) and the detection range."""

    ranges_m: np.ndarray
    pd: np.ndarray
    pd_lower: np.ndarray
    pd_upper: np.ndarray
    threshold_sigma: float
    false_alarms_per_hour: float
    n_pixels: int
    pd_goal: float
    range_m: float | None  # None: Pd never crosses the goal on the grid
    range_lower_m: float | None
    range_upper_m: float | None


def threshold_sigma(false_alarms_per_hour: float, n_pixels: int, fps: float) -> float:
    """Per-pixel threshold [noise sigmas] for ``false_alarms_per_hour`` over ``n_pixels``."""
    if not (false_alarms_per_hour > 0 and math.isfinite(false_alarms_per_hour)):
        raise ValueError(f"false-alarm rate must be > 0 per hour, got {false_alarms_per_hour!r}")
    if n_pixels < 1 or not fps > 0:
        raise ValueError(f"need >= 1 pixel and fps > 0, got {n_pixels}, {fps}")
    p = false_alarms_per_hour / (3600.0 * fps) / n_pixels
    if not p < 0.5:
        raise ValueError(f"false-alarm rate {false_alarms_per_hour}/h is above one per pixel")
    return float(-ndtri(p))


def _crossing(ranges: np.ndarray, pd: np.ndarray, goal: float) -> float | None:
    """Farthest range where ``pd`` (per range, ascending ranges) is still >= goal,
    interpolated linearly; None if it never is or never drops below it."""
    above = np.nonzero(pd >= goal)[0]
    if above.size == 0 or above[-1] == len(ranges) - 1:
        return None
    i = int(above[-1])
    f = (pd[i] - goal) / (pd[i] - pd[i + 1])
    return float(ranges[i] + f * (ranges[i + 1] - ranges[i]))


def detection(
    sensor: Sensor,
    target: Target,
    ranges_m,
    *,
    false_alarms_per_hour: float = 1.0,
    n_pixels: int | None = None,
    pd_goal: float = 0.5,
    phases: int = 5,
    max_draws: int = 60,
    **predict_kwargs,
) -> Detection:
    """Pd(R) and the detection range (module docstring); ``n_pixels`` defaults to the whole
    frame, ``predict_kwargs`` go to :func:`snrmon.model.snr.predict` (atmosphere, sky, PSF...)."""
    if not 0.0 < pd_goal < 1.0:
        raise ValueError(f"Pd goal must be in (0, 1), got {pd_goal!r}")
    r = np.sort(np.atleast_1d(np.asarray(ranges_m, float)))
    npx = int(n_pixels or sensor.width_px * sensor.height_px)
    k = threshold_sigma(false_alarms_per_hour, npx, sensor.fps)
    p = predict(sensor, target, r, expected=False, band=True, **predict_kwargs)
    psf = predict_kwargs.get("corrected_psf") or sensor.corrected_psf()
    ph = phase_grid(phases)
    amp = p.point_contrast_e["small"] / p.noise.total
    d_px = target.small_m / (r * sensor.ifov_rad)
    mc = p.draws
    scale = (
        mc.snr["small_corrected"][:max_draws] / mc.nominal["small_corrected"]
        if mc is not None
        else np.ones((1, r.size))
    )
    pd = np.empty(r.size)
    pd_draws = np.empty((scale.shape[0], r.size))
    for j in range(r.size):
        pats = pixel_patterns(psf, sensor.fill_factor, ph, ph, target_square_px=float(d_px[j]))
        a = amp[j] * pats.reshape(-1, pats.shape[-2] * pats.shape[-1])  # (phases, pixels)
        pd[j] = float(np.mean(1.0 - np.prod(ndtr(k - a), axis=1)))
        scaled = scale[:, j, None, None] * a[None]
        pd_draws[:, j] = np.mean(1.0 - np.prod(ndtr(k - scaled), axis=2), axis=1)
    lo, hi = np.quantile(pd_draws, (0.16, 0.84), axis=0)
    per_draw = [_crossing(r, row, pd_goal) for row in pd_draws]
    found = np.array([x for x in per_draw if x is not None], float)
    r_lo, r_hi = (None, None)
    if found.size >= 0.9 * len(per_draw):
        r_lo, r_hi = (float(v) for v in np.quantile(found, (0.16, 0.84)))
    return Detection(
        ranges_m=r,
        pd=pd,
        pd_lower=lo,
        pd_upper=hi,
        threshold_sigma=k,
        false_alarms_per_hour=float(false_alarms_per_hour),
        n_pixels=npx,
        pd_goal=float(pd_goal),
        range_m=_crossing(r, pd, pd_goal),
        range_lower_m=r_lo,
        range_upper_m=r_hi,
    )
