"""The NumPy/OpenCV segmentation as it was before it was compiled (branch point 717d7ff of
acquisition/measure/blob.py, unchanged but for this docstring and the imports): the reference
the compiled analysis must equal bit for bit (tests/acquisition/measure/test_compiled_exact.py). Its
configuration and result types are imported from the product, not copied."""

from __future__ import annotations

import math

import cv2
import numpy as np

# The data it works with are the product's own (their fields are not what is compared).
from snrmon.acquisition.measure.blob import Blob, BlobConfig, Box
from snrmon.acquisition.measure.local_sky import (
    darkest_side_level,
    flatten_sky,
    looks_level,
    median,
    ring_sides,
    robust_sigma,
    side_levels,
)

_FLAGS = 8 | cv2.FLOODFILL_FIXED_RANGE | cv2.FLOODFILL_MASK_ONLY | (1 << 8)


class _Window:
    """The float32 window of a frame, its noise, the sky's tilt removed, and the connected set
    at a level. One per window: every climb and level of an analysis reuses it."""

    def __init__(self, frame: np.ndarray, x: int, y: int, half: int, cfg, sigma) -> None:
        rows, cols = frame.shape
        self.frame_shape: tuple[int, int] = (rows, cols)
        self.x0, self.x1 = max(x - half, 0), min(x + half, cols - 1)
        self.y0, self.y1 = max(y - half, 0), min(y + half, rows - 1)
        self.v = np.array(frame[self.y0 : self.y1 + 1, self.x0 : self.x1 + 1], np.float32)
        h, w = self.v.shape
        self.mask = np.zeros((h + 2, w + 2), np.uint8)
        self.integer = frame.dtype.kind in "ui"
        self.finite = bool(np.isfinite(self.v).all())
        sig = robust_sigma(self.v) if sigma is None else float(sigma)
        floor = cfg.sigma_floor_dn if self.integer else 1e-6
        self.sigma = max(sig, floor)
        levels = side_levels(self.v, cfg.ring_px)
        if (
            cfg.flatten
            and self.finite
            and not looks_level(levels, self.sigma)
            and flatten_sky(self.v, self.sigma)
        ):
            self.integer = False  # levels are no longer whole numbers
            levels = side_levels(self.v, cfg.ring_px)
        self.background = darkest_side_level(levels)
        # The extent's noise: the sky's own roughness around the window (a curved gradient
        # an AGC leaves, structure) where it exceeds the pixel noise.
        ring = np.concatenate(ring_sides(self.v, cfg.ring_px))
        if not np.isfinite(ring).all():
            ring = ring[np.isfinite(ring)]
        spread = 1.4826 * median(np.abs(ring - median(ring))) if ring.size else 0.0
        self.sky_sigma = max(self.sigma, spread)

    def inside(self, x: int, y: int, room: int) -> bool:
        """True when frame pixel (x, y) is at least ``room`` px inside the window's border
        (an image edge counts as inside: the window cannot move past it)."""
        return not _near_border(self, (x, y, x, y), room)

    def component(self, sx: int, sy: int, level: float):
        """(mask view, area, (x, y, w, h)) of the set >= level containing the seed (window px)."""
        self.mask.fill(0)
        lo = max(float(self.v[sy, sx]) - level, 0.0)
        area, _, _, rect = cv2.floodFill(self.v, self.mask, (sx, sy), 0, (lo,), (1e30,), _FLAGS)
        return self.mask[1:-1, 1:-1], int(area), rect

    def touches(self, rect) -> bool:
        rx, ry, rw, rh = rect
        h, w = self.v.shape
        return rx == 0 or ry == 0 or rx + rw == w or ry + rh == h

    def is_open(self, sx: int, sy: int, level: float, peak: float) -> bool:
        m, _, rect = self.component(sx, sy, level)
        if self.touches(rect):
            return True
        rx, ry, rw, rh = rect
        sub = (slice(ry, ry + rh), slice(rx, rx + rw))
        return cv2.minMaxLoc(self.v[sub], m[sub])[1] > peak

    def frame_box(self, rect) -> Box:
        rx, ry, rw, rh = rect
        return (self.x0 + rx, self.y0 + ry, self.x0 + rx + rw - 1, self.y0 + ry + rh - 1)


def _near_border(win: _Window, box: Box, room: int) -> bool:
    """True when ``box`` comes within ``room`` px of a window border that is not the image's
    edge (the window's clipped sides)."""
    x0, y0, x1, y1 = box
    rows, cols = win.frame_shape
    return (
        (win.x0 > 0 and x0 - win.x0 < room)
        or (win.y0 > 0 and y0 - win.y0 < room)
        or (win.x1 < cols - 1 and win.x1 - x1 < room)
        or (win.y1 < rows - 1 and win.y1 - y1 < room)
    )


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
        win = _Window(frame, cx, cy, half, cfg, sigma)
        blob, (x, y), redo, grow = _analyse(win, x, y, cfg)
        if redo:
            cx, cy = x, y  # the climb left the window's middle: centre on the new seed
        elif grow and half < cfg.max_half_px:
            half = min(2 * half, cfg.max_half_px)
        else:
            return blob
    return blob


def _argmax_in(win: _Window, m: np.ndarray, rect) -> tuple[int, int, float]:
    """Window (x, y) and value of the brightest pixel of a set, first in row-major order."""
    rx, ry, rw, rh = rect
    sub = np.where(m[ry : ry + rh, rx : rx + rw] > 0, win.v[ry : ry + rh, rx : rx + rw], -np.inf)
    i = int(np.argmax(sub))
    return rx + i % rw, ry + i // rw, float(sub.flat[i])


def _climb(win: _Window, sx: int, sy: int, cfg: BlobConfig) -> tuple[int, int]:
    """The top of the seed's hill (window px): the brightest pixel reachable without dipping
    more than ``k_climb`` sigma below the seed, first in row-major order among equals. An
    object behind a deeper valley is another object; a set that reaches the window's border is
    the sky's or the clutter's, where there is nothing to climb. Each step goes up (or to an
    equal pixel earlier in row-major order), so it ends; it is bounded all the same."""
    for _ in range(16):
        peak = float(win.v[sy, sx])
        m, _, rect = win.component(sx, sy, peak - cfg.k_climb * win.sigma)
        if win.touches(rect):
            break
        tx, ty, top = _argmax_in(win, m, rect)
        if not (top > peak or (top == peak and (ty, tx) < (sy, sx))):
            break
        sx, sy = tx, ty
    return sx, sy


def _analyse(win: _Window, x: int, y: int, cfg: BlobConfig):
    """(blob, seed, recentre, window too small) of the seed's object in one window."""
    sx, sy = x - win.x0, y - win.y0
    if not math.isfinite(float(win.v[sy, sx])):
        return None, (x, y), False, False
    sx, sy = _climb(win, sx, sy, cfg)
    x, y = win.x0 + sx, win.y0 + sy
    if not win.inside(x, y, 3):
        return None, (x, y), True, False
    peak = float(win.v[sy, sx])
    sig = win.sigma
    background = win.background if math.isfinite(win.background) else peak
    # Levels to a quarter of the noise, or 1/64 of the contrast, are plenty (whole DN for
    # integer frames).
    step = max(0.25 * sig, (peak - background) / 64.0, 1.0 if win.integer else 0.0)

    # Bisection for the saddle: the highest level at which the seed's set is open. An object
    # on clear sky is closed at the extent's level, which leaves a short interval to bisect.
    lo = min(background, peak)
    probe = min(background + cfg.k_ext * sig, peak)
    if win.is_open(sx, sy, peak, peak):
        saddle = peak
    elif not win.is_open(sx, sy, lo, peak):
        saddle = lo
    else:
        hi = peak
        if win.is_open(sx, sy, probe, peak):
            lo = probe
        else:
            hi = probe
        while hi - lo > step:
            mid = (lo + hi) / 2.0
            if win.integer:
                mid = float(math.floor(mid))
                if mid <= lo:
                    break
            if win.is_open(sx, sy, mid, peak):
                lo = mid
            else:
                hi = mid
        saddle = lo
    core_level = saddle + cfg.core_fraction * (peak - saddle)
    if win.integer:  # the set >= L of integer pixels is the set >= ceil(L)
        core_level = min(max(float(math.ceil(core_level)), saddle + 1.0), peak)
    core_mask, core_area, crect = win.component(sx, sy, core_level)
    cx, cy, cw, ch = crect
    core_in = core_mask[cy : cy + ch, cx : cx + cw] > 0
    weights = np.where(core_in, win.v[cy : cy + ch, cx : cx + cw] - saddle, 0.0)
    total = float(weights.sum())
    if total > 0:
        centroid_x = win.x0 + cx + float(weights.sum(axis=0) @ np.arange(cw)) / total
        centroid_y = win.y0 + cy + float(weights.sum(axis=1) @ np.arange(ch)) / total
    else:
        centroid_x, centroid_y = float(x), float(y)
    # Everything connected to the object more than k_ext sky-sigma above the sky it stands on
    # (the saddle, for an object on clear sky a little above the window's background).
    extent_level = min(max(background, saddle) + cfg.k_ext * win.sky_sigma, core_level)
    _, ext_area, erect = win.component(sx, sy, extent_level)
    extent_box = win.frame_box(erect)
    # Too small a window: the extent nears a border that is not the image's edge, or the
    # object stands less than half its contrast out of a set that meets such a border (a
    # large object cut by the window, rather than one merged with clutter: a larger window
    # tells).
    grow = _near_border(win, extent_box, 2 + cfg.margin_px)
    if not grow and saddle - background > 0.5 * (peak - background) and saddle < peak:
        grow = _near_border(win, win.frame_box(win.component(sx, sy, saddle)[2]), 1)
    blob = Blob(
        peak_x=x,
        peak_y=y,
        peak=peak,
        background=background,
        sigma=sig,
        saddle=saddle,
        core_level=core_level,
        core_area=core_area,
        core_box=win.frame_box(crect),
        centroid_x=centroid_x,
        centroid_y=centroid_y,
        extent_level=extent_level,
        extent_area=ext_area,
        extent_box=extent_box,
        window=(win.x0, win.y0, win.x1, win.y1),
    )
    return blob, (x, y), False, grow
