"""The live noise panel's numbers (paper section 6): total, temporal and spatial noise (DN) of the
background around the track, sampled a few times per second on the measurement thread.

Which pixels: the operator's clear-sky rectangle when the measurement config has one (detrended
by a plane when the config says so); else a ``region_px`` square centred on the tracked peak with
the ``box_px`` box around the peak left out (the drone and its rim are not background noise);
else (no ROI, no rectangle) none, and the figures are unknown (NaN).

How: every ``interval_s`` (default 0.25 s, so at most 4 estimates per second whatever the frame
rate) the chosen pixels of one frame are copied; on the NEXT measured frame the same pixels (same
coordinates, even if the track moved) give :func:`snrmon.acquisition.measure.noise.estimate_noise`
its frame and
previous frame. Temporal noise follows acquisition/measure/noise.py's convention: the std of the
difference of two frames divided by sqrt(2) (the difference carries sqrt(2) times the
single-frame temporal noise); spatial = sqrt(max(total^2 - temporal^2, 0)). The ring of pixels
around the box is not a rectangle: its pixels are passed to ``estimate_noise`` as one row, which
gives the same std (the std of a set does not depend on its arrangement; no detrend there).
Raw camera pixels are used (before any background reference), so the spatial figure is the
camera's own fixed pattern.

The 3D noise beside it (:class:`TrackNoise3d`, :mod:`snrmon.acquisition.measure.noise3d`): the seven
bias-corrected components of a background region over blocks of 100 consecutive measured frames.
The region is the operator's clear-sky rectangle if there is one, else the largest rectangle of
the frame clear of the tracked peak by ``CLEAR_MARGIN_PX``
(:mod:`snrmon.acquisition.measure.background`; a full-width band above or below it, or a
full-height band beside it), cropped to :data:`LIVE_MAX_PIXELS_3D` pixels nearest the target so
that a frame costs ~0.15 ms (a 256 x 256 crop 0.47 ms; the full 1280 x 399 band of a 1280 x 720
frame ~3.5 ms): 100 frames of 128 x 128 pixels pin sigma_tvh to 0.1 % and sigma_vh to ~1 %
(95 %; sigma_vh well above sigma_tvh / 10).
The region stays put while the target stays clear of it; when the target enters it (or the track
is lost) the block restarts. The figure shown is that of the last complete block.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from snrmon.acquisition.measure.background import (
    CLEAR_MARGIN_PX,
    Rect,
    clear_region,
    overlaps,
    target_box,
    validate_rect,
)
from snrmon.acquisition.measure.jit import kernel, std_ddof
from snrmon.acquisition.measure.noise import NoiseEstimate, estimate_noise, noise_estimate
from snrmon.acquisition.measure.noise3d import Noise3d, Noise3dSums

NAN = math.nan
FRAMES_3D = 100  # the console's window, like the running SNR statistics
LIVE_MAX_PIXELS_3D = 128 * 128


def ring_pixels(
    shape: tuple[int, int], peak_xy: tuple[int, int], region_px: int, box_px: int
) -> tuple[np.ndarray, np.ndarray]:
    """(rows, cols) of a ``region_px`` square centred on ``peak_xy`` (clipped to the image),
    without the ``box_px`` box centred on it: the background around the track."""
    h, w = shape
    x, y = peak_xy
    r, b = region_px // 2, box_px // 2
    ys = np.arange(max(y - r, 0), min(y + r, h - 1) + 1)
    xs = np.arange(max(x - r, 0), min(x + r, w - 1) + 1)
    rows, cols = np.meshgrid(ys, xs, indexing="ij")
    keep = (np.abs(rows - y) > b) | (np.abs(cols - x) > b)
    return rows[keep].astype(np.intp), cols[keep].astype(np.intp)


@kernel
def ring_values(pixels, x, y, r, b, h, w):
    """The pixels of :func:`ring_pixels` (image ``h`` x ``w``) as float64, in its order."""
    ys0, ys1 = max(y - r, 0), min(y + r, h - 1)
    xs0, xs1 = max(x - r, 0), min(x + r, w - 1)
    out = np.empty(max(ys1 - ys0 + 1, 0) * max(xs1 - xs0 + 1, 0))
    n = 0
    for yy in range(ys0, ys1 + 1):
        for xx in range(xs0, xs1 + 1):
            if abs(yy - y) > b or abs(xx - x) > b:
                out[n] = np.float64(pixels[yy, xx])
                n += 1
    return out[:n]


@kernel
def _difference(here, previous):
    out = np.empty(here.size)
    for i in range(here.size):
        out[i] = here[i] - previous[i]
    return out


def _ring_estimate(here: np.ndarray, previous: np.ndarray, ddof: int) -> NoiseEstimate:
    """:func:`snrmon.acquisition.measure.noise.estimate_noise` of the ring's pixels as one row (no
    detrend): the same pairwise sums, compiled (:func:`snrmon.acquisition.measure.jit.std_ddof`)."""
    total = std_ddof(here, ddof)
    temporal_paper = std_ddof(_difference(here, previous), ddof)
    return noise_estimate(total, temporal_paper, here.size, False)


@dataclass(frozen=True, slots=True)
class RegionNoise3d:
    """The 3D noise of one block of frames and the region it was measured on (x0, y0, x1, y1,
    both corners included)."""

    region: Rect
    noise: Noise3d


class TrackNoise3d:
    """3D noise of the background clear of the track, over blocks of ``frames`` measured frames
    (module docstring). One thread calls :meth:`update`; any thread may read :attr:`latest`."""

    def __init__(
        self,
        shape: tuple[int, int],
        *,
        background: Rect | None = None,
        frames: int = FRAMES_3D,
        margin_px: int = CLEAR_MARGIN_PX,
        max_pixels: int | None = LIVE_MAX_PIXELS_3D,
    ) -> None:
        if frames < 2:
            raise ValueError(f"3D noise needs blocks of at least 2 frames, got {frames}")
        self.shape = (int(shape[0]), int(shape[1]))
        self.fixed = None if background is None else validate_rect(background, self.shape)
        self.frames = int(frames)
        self.margin_px = int(margin_px)
        self.max_pixels = max_pixels
        self.region: Rect | None = self.fixed
        self.latest: RegionNoise3d | None = None
        self._sums: Noise3dSums | None = None

    def update(self, pixels: np.ndarray, peak_xy: tuple[int, int] | None) -> None:
        """Feed one measured frame (raw pixels) and the tracked peak (None: no track)."""
        if self.fixed is None:
            if peak_xy is None:  # where the target is is unknown: start again once found
                self.region, self._sums = None, None
                return
            box = target_box(self.shape, [peak_xy], margin_px=self.margin_px)
            if self.region is None or overlaps(self.region, box):
                self.region = clear_region(self.shape, box, max_pixels=self.max_pixels)
                self._sums = None
        if self.region is None:  # the target leaves no clear band of 2 x 2 pixels
            return
        x0, y0, x1, y1 = self.region
        if self._sums is None:
            self._sums = Noise3dSums(y1 - y0 + 1, x1 - x0 + 1)
        self._sums.add(pixels[y0 : y1 + 1, x0 : x1 + 1])
        if self._sums.frames >= self.frames:
            self.latest = RegionNoise3d(self.region, self._sums.result())
            self._sums = None


class TrackNoise:
    """Section 6 noise around the track, at most once per ``interval_s`` (not thread-safe: one
    measurement thread calls :meth:`update`; any thread may read :attr:`latest`)."""

    def __init__(
        self,
        shape: tuple[int, int],
        *,
        box_px: int = 7,
        background: Rect | None = None,
        detrend: bool = False,
        ddof: int = 1,
        region_px: int = 41,
        interval_s: float = 0.25,
    ) -> None:
        if region_px <= box_px or region_px % 2 == 0:
            raise ValueError(
                f"noise region must be an odd size larger than the {box_px}-px box, got {region_px}"
            )
        if not interval_s > 0:
            raise ValueError(f"noise interval must be positive seconds, got {interval_s}")
        self.shape = (int(shape[0]), int(shape[1]))
        self.box_px = int(box_px)
        self.rect = None if background is None else validate_rect(background, self.shape)
        self.detrend = bool(detrend) and self.rect is not None
        self.ddof = int(ddof)
        self.region_px = int(region_px)
        self.interval_ns = int(interval_s * 1e9)
        self.latest: NoiseEstimate | None = None
        self.cube = TrackNoise3d(self.shape, background=self.rect)
        self.estimates = 0
        self._armed: tuple[Any, np.ndarray] | None = None  # (pixel selection, their values)
        self._last_ns: int | None = None

    def _selection(self, peak_xy: tuple[int, int] | None):
        if self.rect is not None:
            x0, y0, x1, y1 = self.rect
            return (slice(y0, y1 + 1), slice(x0, x1 + 1))
        if peak_xy is None:
            return None
        sel = ring_pixels(self.shape, peak_xy, self.region_px, self.box_px)
        return sel if sel[0].size > self.ddof + 1 else None

    def update(self, pixels: np.ndarray, t_host_ns: int, peak_xy: tuple[int, int] | None) -> None:
        """Feed one measured frame (raw pixels) and the tracked peak (None: no track)."""
        self.cube.update(pixels, peak_xy)
        if self._armed is not None and self.rect is None:  # the ring: compiled
            (x, y), previous = self._armed
            self._armed = None
            here = self._ring(pixels, x, y)
            self.latest = _ring_estimate(here, previous, self.ddof)
            self.estimates += 1
            return
        if self._armed is not None:
            sel, previous = self._armed
            self._armed = None
            here = pixels[sel]
            if here.ndim == 1:  # the ring around the box: one row of pixels
                here, previous = here.reshape(1, -1), previous.reshape(1, -1)
            self.latest = estimate_noise(here, previous, detrend=self.detrend, ddof=self.ddof)
            self.estimates += 1
            return
        if self._last_ns is not None and t_host_ns - self._last_ns < self.interval_ns:
            return
        if self.rect is None and peak_xy is not None:
            x, y = int(peak_xy[0]), int(peak_xy[1])
            values = self._ring(pixels, x, y)
            if values.size <= self.ddof + 1:
                self.latest = None
                return
            self._armed = ((x, y), values)
            self._last_ns = t_host_ns
            return
        sel = self._selection(peak_xy)
        if sel is None:
            self.latest = None  # no background to measure: unknown, not a stale figure
            return
        self._armed = (sel, pixels[sel].copy())
        self._last_ns = t_host_ns

    def _ring(self, pixels: np.ndarray, x: int, y: int) -> np.ndarray:
        """The :func:`ring_pixels` of (x, y) as float64, row-major (compiled)."""
        r, b = self.region_px // 2, self.box_px // 2
        return ring_values(pixels, x, y, r, b, self.shape[0], self.shape[1])

    def figures(self) -> tuple[float, float, float]:
        """(total_dn, temporal_dn, spatial_dn) of the latest estimate, NaN when unknown."""
        est = self.latest
        if est is None:
            return NAN, NAN, NAN
        return est.total_dn, est.temporal_dn, est.spatial_dn
