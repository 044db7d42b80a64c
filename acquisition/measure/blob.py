"""The compact bright object around a pixel: its peak, prominence, core and extent.

What the tracker follows and what the target-aware measurement keeps out of its background.
Given a seed pixel, the object is analysed in a square window by the connected set of pixels at
or above a level that contains the seed (8-connectivity), on the window with a sloping sky
flattened (:func:`snrmon.acquisition.measure.local_sky.flatten_sky`):

- **climb**: the seed first moves to the top of its hill, the brightest pixel reachable without
  dipping more than ``k_climb`` (3) sigma below it (a plateau's noise, a flank), the first in
  row-major order among equals (the Eq. 4 convention). Nothing is climbed on a set that reaches
  the window's border (the sky's, the clutter's).
- **open** at level L: the seed's set touches the window's border or holds a pixel brighter than
  the peak. Lowering L only grows the set, so there is one **saddle**: the highest level at
  which it is open (bisection, to a quarter sigma or 1/64 of the contrast). Below it the object
  has joined something larger (the sky, a treeline, a cloud bank) or brighter (another object).
  Closed even at the background level: the saddle is the background.
- **prominence** = peak - saddle: how far the object stands out of what it joins (a hill's
  topographic prominence). A drone on sky: nearly its whole contrast; a bump in a treeline's
  texture: a small part of its contrast; a pixel inside a saturated region: 0.
  **significance** = prominence / sigma; **contrast** = peak - background.
- **core**: the set at ``core_fraction`` (0.5) of the way from the saddle to the peak (the
  full width at half maximum of an isolated object). Its centroid (weights = pixel - saddle) is
  the object's position; its area and box are what the tracker compares frame to frame.
- **extent**: the set at ``max(background, saddle) + k_ext x sky sigma`` (``k_ext`` = 3, capped
  at the core's level): every pixel connected to the object that carries more than 3 sigma of
  its signal above the sky it stands on, cut where it joins clutter. The measurement's
  background must lie outside it (:mod:`snrmon.acquisition.measure.target_snr`).

The window starts at ``min_half_px`` (8) and doubles, up to ``max_half_px`` (48), while the
extent comes within ``2 + margin_px`` pixels of a border that is not the image's edge, or while
the object stands less than half its contrast out of a set that meets such a border (a large
drone cut by the window rather than one merged with clutter): an isolated object is seen whole
whatever its size, and an unresolved one costs a 17 x 17 window.

Levels: ``background`` is the lowest of the medians of the four sides of the window's border
ring (``ring_px`` wide; the sky beside a treeline, not a mix); ``sigma`` the robust pixel noise
(1.4826 MAD of neighbour differences / sqrt(2), or the caller's), at least ``sigma_floor_dn``
(0.5 DN for integer frames: a flat 8-bit sky can have a MAD of 0); the **sky sigma** of the
extent is the larger of that and the robust spread of the border ring (an AGC'd sky's curvature).

Conventions: x = column, y = row, zero-based, integers at pixel centres; boxes ``(x0, y0, x1,
y1)`` with both corners included; levels in the frame's DN after the flattening. Only the
window is read.

The analysis of a window is compiled (:mod:`snrmon.acquisition.measure.blob_kernel`): the same sets,
levels and sums as the NumPy/OpenCV code it replaced, bit for bit (the reference is kept in
``tests/reference/blob_numpy.py`` and compared on random scenes); the plane fit stays NumPy's.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from snrmon.acquisition.measure.blob_kernel import analyse_auto, analyse_window, window_stats
from snrmon.acquisition.measure.local_sky import (
    darkest_side_level,
    flatten_sky,
    looks_level,
    median,
    ring_sides,
    robust_sigma,
    side_levels,
)

Box = tuple[int, int, int, int]


@dataclass(frozen=True)
class BlobConfig:
    """Every number of the object analysis (module docstring)."""

    min_half_px: int = 8
    max_half_px: int = 48
    margin_px: int = 2
    ring_px: int = 2
    k_ext: float = 3.0
    core_fraction: float = 0.5
    k_climb: float = 3.0
    sigma_floor_dn: float = 0.5
    flatten: bool = True

    def __post_init__(self) -> None:
        if not 3 <= self.min_half_px <= self.max_half_px:
            raise ValueError(
                f"need 3 <= min_half_px <= max_half_px, got {self.min_half_px}, {self.max_half_px}"
            )
        if not 0.0 < self.core_fraction < 1.0:
            raise ValueError(f"core_fraction must be in (0, 1), got {self.core_fraction}")
        if self.k_ext <= 0 or self.ring_px < 1 or self.margin_px < 0 or self.sigma_floor_dn < 0:
            raise ValueError("k_ext > 0, ring_px >= 1, margin_px >= 0, sigma_floor_dn >= 0")


@dataclass(frozen=True, slots=True)
class Blob:
    """One object (module docstring). Levels and values in DN, positions in frame pixels."""

    peak_x: int
    peak_y: int
    peak: float
    background: float
    sigma: float
    saddle: float
    core_level: float
    core_area: int
    core_box: Box
    centroid_x: float
    centroid_y: float
    extent_level: float
    extent_area: int
    extent_box: Box
    window: Box  # the window the analysis read (inclusive)

    @property
    def prominence(self) -> float:
        return self.peak - self.saddle

    @property
    def contrast(self) -> float:
        """Peak above the local background level."""
        return self.peak - self.background

    @property
    def significance(self) -> float:
        """Prominence in units of the noise."""
        return self.prominence / self.sigma

    @property
    def core_size(self) -> tuple[int, int]:
        x0, y0, x1, y1 = self.core_box
        return x1 - x0 + 1, y1 - y0 + 1

    @property
    def extent_size(self) -> tuple[int, int]:
        x0, y0, x1, y1 = self.extent_box
        return x1 - x0 + 1, y1 - y0 + 1

    def extent_within(self, half_px: int) -> bool:
        """True when every extent pixel is within ``half_px`` (Chebyshev) of the peak."""
        x0, y0, x1, y1 = self.extent_box
        px, py = self.peak_x, self.peak_y
        return max(px - x0, x1 - px, py - y0, y1 - py) <= half_px


@functools.lru_cache(maxsize=16)
def _numbers(cfg: BlobConfig) -> tuple[float, float, float, float]:
    return (cfg.k_climb, cfg.k_ext, cfg.core_fraction, float(cfg.margin_px))


def analyse_blob(
    frame: np.ndarray,
    seed_xy: tuple[int, int],
    config: BlobConfig | None = None,
    *,
    sigma: float | None = None,
    min_half_px: int | None = None,
    centre_xy: tuple[int, int] | None = None,
) -> Blob | None:
    """The object around the seed pixel (module docstring); None when the seed is not finite.

    The seed climbs to the top of its hill, so a seed on the object's flank still gives the
    object's peak. ``min_half_px`` starts the window larger and ``centre_xy`` centres it (a
    tracker that knows the object's size and where it should be); ``sigma`` (DN) replaces the
    window's estimate.
    """
    cfg = config or BlobConfig()
    x, y = int(seed_xy[0]), int(seed_xy[1])
    half = min(max(cfg.min_half_px, min_half_px or 0), cfg.max_half_px)
    cx, cy = (x, y) if centre_xy is None else (int(centre_xy[0]), int(centre_xy[1]))
    for _ in range(8):  # recentrings and doublings, both bounded
        if max(abs(x - cx), abs(y - cy)) > half - 2:
            cx, cy = x, y
        blob, (x, y), redo, grow = _analyse(frame, cx, cy, half, x, y, cfg, sigma)
        if redo:
            cx, cy = x, y  # the climb left the window's middle: centre on the new seed
        elif grow and half < cfg.max_half_px:
            half = min(2 * half, cfg.max_half_px)
        else:
            return blob
    return blob


def _stats(v: np.ndarray, ring_px: int) -> tuple[bool, float, list[float], float]:
    """(finite, robust sigma, side levels, ring spread) of a float32 window."""
    finite, estimate, sides, levels, spread = window_stats(v, ring_px)
    if sides:
        return finite, estimate, levels[:sides].tolist(), spread
    # A -0.0 pixel: NumPy's medians (module docstring of blob_kernel).
    ring = np.concatenate(ring_sides(v, ring_px))
    if not np.isfinite(ring).all():
        ring = ring[np.isfinite(ring)]
    spread = 1.4826 * median(np.abs(ring - median(ring))) if ring.size else 0.0
    return finite, robust_sigma(v), side_levels(v, ring_px), spread


def _analyse(frame: np.ndarray, cx: int, cy: int, half: int, x: int, y: int, cfg, sigma):
    """(blob, seed, recentre, window too small) of the seed (x, y)'s object in the window of
    half-size ``half`` around (cx, cy): its float32 pixels, their noise and levels, the sky's
    tilt removed (NumPy), then the compiled analysis
    (:mod:`snrmon.acquisition.measure.blob_kernel`)."""
    rows, cols = frame.shape
    x0, x1 = max(cx - half, 0), min(cx + half, cols - 1)
    y0, y1 = max(cy - half, 0), min(cy + half, rows - 1)
    v = np.array(frame[y0 : y1 + 1, x0 : x1 + 1], np.float32)
    integer = frame.dtype.kind in "ui"
    floor = cfg.sigma_floor_dn if integer else 1e-6
    geo = (x0, y0, x1, y1, rows, cols)
    given = 0.0 if sigma is None else float(sigma)
    args = (geo, x - x0, y - y0)
    out = analyse_auto(
        v, *args, given, sigma is not None, floor, integer, cfg.flatten, cfg.ring_px, _numbers(cfg)
    )
    after_plane = False
    if out[0] == 5:  # a sloping sky: the plane fit is NumPy's (LAPACK)
        sig, after_plane = out[6], True
        if flatten_sky(v, sig):
            integer = False  # levels are no longer whole numbers
        out = analyse_auto(v, *args, sig, True, floor, integer, False, cfg.ring_px, _numbers(cfg))
    if out[0] == 4:  # a -0.0 pixel: NumPy's medians
        finite, estimate, side, spread = _stats(v, cfg.ring_px)
        if not after_plane:  # else the sigma before the plane fit stands
            sig = max(estimate if sigma is None else float(sigma), floor)
        plane = cfg.flatten and not after_plane and finite
        if plane and not looks_level(side, sig) and flatten_sky(v, sig):
            integer = False
            _, _, side, spread = _stats(v, cfg.ring_px)
        # The extent's noise: the sky's own roughness around the window (a curved gradient
        # an AGC leaves, structure) where it exceeds the pixel noise.
        out = (
            *analyse_window(
                v, *args, sig, darkest_side_level(side), max(sig, spread), integer, _numbers(cfg)
            ),
            sig,
        )
    status, sx, sy, vals, boxes, labels, sig = out
    x, y = x0 + sx, y0 + sy
    if status < 2:
        return None, (x, y), status == 1, False
    peak, bg, saddle, core_level, centroid_x, centroid_y, extent_level, grow, _ = vals.tolist()
    area, cx0, cy0, cx1, cy1, ext_area, ex0, ey0, ex1, ey1, core = boxes.tolist()
    if status == 3:  # the centroid's sums not provably exact in any order: NumPy's own
        cw, ch = cx1 - cx0 + 1, cy1 - cy0 + 1
        core_in = labels[cy0 : cy0 + ch, cx0 : cx0 + cw] == core
        weights = np.where(core_in, v[cy0 : cy0 + ch, cx0 : cx0 + cw] - saddle, 0.0)
        total = float(weights.sum())
        if total > 0:
            centroid_x = x0 + cx0 + float(weights.sum(axis=0) @ np.arange(cw)) / total
            centroid_y = y0 + cy0 + float(weights.sum(axis=1) @ np.arange(ch)) / total
    blob = Blob(
        peak_x=x,
        peak_y=y,
        peak=peak,
        background=bg,
        sigma=sig,
        saddle=saddle,
        core_level=core_level,
        core_area=area,
        core_box=(x0 + cx0, y0 + cy0, x0 + cx1, y0 + cy1),
        centroid_x=centroid_x,
        centroid_y=centroid_y,
        extent_level=extent_level,
        extent_area=ext_area,
        extent_box=(ex0, ey0, ex1, ey1),
        window=(x0, y0, x1, y1),
    )
    return blob, (x, y), False, grow > 0
