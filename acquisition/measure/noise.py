"""Noise analysis of paper section 6: total, temporal and spatial (fixed-pattern) noise in DN.

* total noise: the std of the background pixels of ONE frame (optionally detrended by a plane);
* temporal noise: from the difference of this frame and the previous one, over the same pixels.
  The difference of two frames with independent temporal noise sigma_t has std sqrt(2)*sigma_t
  (and the fixed pattern cancels), so the physically right single-frame estimate is
  ``std(frame - previous) / sqrt(2)`` -> ``temporal_dn``. The paper's operational definition
  ("the standard deviation of the background pixels after subtracting the previous frame") is
  the UNSCALED std of the difference -> ``temporal_paper_dn`` (sqrt(2) larger);
* spatial noise: ``sqrt(max(total^2 - temporal^2, 0))`` -> ``spatial_dn`` with the scaled
  temporal noise, ``spatial_paper_dn`` with the paper's literal one.

The std uses ``ddof`` (1 = sample std, MATLAB ``std``). Frames are converted to float64 before
subtracting, so unsigned integer frames do not wrap.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from snrmon.acquisition.measure.background import Rect, detrended, rect_offsets, validate_rect

SQRT2 = math.sqrt(2.0)


@dataclass(frozen=True, slots=True)
class NoiseEstimate:
    """Section 6 noise figures of one frame, in DN (NaN where no previous frame was given).

    Attributes:
        total_dn: std of the background pixels of this frame.
        temporal_dn: std of (frame - previous) / sqrt(2): the single-frame temporal noise.
        spatial_dn: sqrt(max(total^2 - temporal^2, 0)).
        temporal_paper_dn: std of (frame - previous), unscaled (the paper's literal definition).
        spatial_paper_dn: sqrt(max(total^2 - temporal_paper^2, 0)).
        n_pixels: background pixels used.
        detrended: whether a least-squares plane was removed before each std.
    """

    total_dn: float
    temporal_dn: float
    spatial_dn: float
    temporal_paper_dn: float
    spatial_paper_dn: float
    n_pixels: int
    detrended: bool


def _std(values: np.ndarray, dy: np.ndarray, dx: np.ndarray, detrend: bool, ddof: int) -> float:
    v = values.reshape(1, -1)
    dev = detrended(v, dy, dx) if detrend else v - v.mean()
    return float(np.sqrt((dev * dev).sum() / (v.size - ddof)))


def _quadrature_rest(total: float, part: float) -> float:
    if not math.isfinite(part):
        return math.nan
    return math.sqrt(max(total * total - part * part, 0.0))


def estimate_noise(
    frame: np.ndarray,
    previous: np.ndarray | None = None,
    *,
    region: Rect | None = None,
    detrend: bool = False,
    ddof: int = 1,
) -> NoiseEstimate:
    """Section 6 noise of ``frame`` over the background ``region`` (x0, y0, x1, y1, both corners
    included; None = the whole frame), with the temporal part from ``previous`` if given."""
    if frame.ndim != 2:
        raise ValueError(f"a frame must be 2-D (rows, columns), got shape {frame.shape}")
    if previous is not None and previous.shape != frame.shape:
        raise ValueError(f"previous frame shape {previous.shape} differs from {frame.shape}")
    rows, cols = frame.shape
    rect = (0, 0, cols - 1, rows - 1) if region is None else region
    x0, y0, x1, y1 = validate_rect(rect, (rows, cols), min_pixels=ddof + (3 if detrend else 1))
    dy, dx = rect_offsets((x0, y0, x1, y1))
    here = frame[y0 : y1 + 1, x0 : x1 + 1].astype(np.float64)
    total = _std(here, dy, dx, detrend, ddof)
    if previous is None:
        temporal_paper = math.nan
    else:
        diff = here - previous[y0 : y1 + 1, x0 : x1 + 1].astype(np.float64)
        temporal_paper = _std(diff, dy, dx, detrend, ddof)
    return noise_estimate(total, temporal_paper, here.size, detrend)


def noise_estimate(
    total: float, temporal_paper: float, n_pixels: int, detrended: bool
) -> NoiseEstimate:
    """Section 6's three figures from the total noise and the std of the frame difference (the
    paper's temporal noise, sqrt(2) times a single frame's)."""
    temporal = temporal_paper / SQRT2
    return NoiseEstimate(
        total_dn=total,
        temporal_dn=temporal,
        spatial_dn=_quadrature_rest(total, temporal),
        temporal_paper_dn=temporal_paper,
        spatial_paper_dn=_quadrature_rest(total, temporal_paper),
        n_pixels=n_pixels,
        detrended=detrended,
    )


class NoiseMeter:
    """Section 6 noise frame after frame: keeps a copy of the previous frame's region only."""

    def __init__(self, region: Rect | None = None, *, detrend: bool = False, ddof: int = 1):
        self.region = region
        self.detrend = detrend
        self.ddof = ddof
        self._previous: np.ndarray | None = None

    def update(self, frame: np.ndarray) -> NoiseEstimate:
        """Noise of this frame (temporal from the frame before; NaN on the first)."""
        if self.region is None:
            here = frame
            rect = None
        else:
            x0, y0, x1, y1 = validate_rect(self.region, frame.shape)
            here = frame[y0 : y1 + 1, x0 : x1 + 1]
            rect = (0, 0, x1 - x0, y1 - y0)
        prev = (
            self._previous
            if self._previous is not None and self._previous.shape == here.shape
            else None
        )
        est = estimate_noise(here, prev, region=rect, detrend=self.detrend, ddof=self.ddof)
        self._previous = here.copy()
        return est

    def reset(self) -> None:
        self._previous = None
