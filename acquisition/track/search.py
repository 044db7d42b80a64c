"""Finding compact objects in a square of the frame: the click, the lost-track search.

:func:`find_objects` proposes seeds and lets :func:`snrmon.acquisition.measure.blob.analyse_blob`
judge each one. Seeds: the brightest pixel of each connected group of pixels that stand
``seed_sigma`` noise above a local mean (a ``k x k`` box blur, ``k`` about three times the
expected object size, so a large drone is not blurred into its own background) and whose
brightest pixel stands 0.6 x ``min_significance`` sigma above it (the noise's own groups do
not), small groups nearest the square's centre first, plus any given seeds. An object is kept
when it is significant (prominence >= ``min_significance`` sigma) and isolated (prominence >=
``min_isolation`` of its contrast over the local background): a drone on sky stands out of the
sky by nearly its whole contrast, a bump in a treeline's or cloud's texture by a small part of
it, and a pixel inside a saturated region by nothing.

Conventions: x = column, y = row, zero-based; boxes ``(x0, y0, x1, y1)`` with both included.
"""

from __future__ import annotations

import math
from typing import TypeGuard

import cv2
import numpy as np
from scipy import ndimage

from snrmon.acquisition.measure.blob import Blob, BlobConfig, Box, analyse_blob
from snrmon.acquisition.measure.local_sky import robust_sigma
from snrmon.acquisition.measure.rim_kernel import brightest


def clip_box(box: Box, shape: tuple[int, int]) -> Box | None:
    """``box`` cut to an image of ``shape`` = (rows, columns); None when nothing is left."""
    rows, cols = shape
    x0, y0, x1, y1 = max(box[0], 0), max(box[1], 0), min(box[2], cols - 1), min(box[3], rows - 1)
    if x1 < x0 or y1 < y0:
        return None
    return x0, y0, x1, y1


def brightest_in(frame: np.ndarray, box: Box) -> tuple[int, int] | None:
    """The brightest pixel of ``box`` (first in row-major order among equals; NaN never)."""
    b = clip_box(box, frame.shape)
    if b is None:
        return None
    x0, y0, x1, y1 = b
    i = brightest(frame[y0 : y1 + 1, x0 : x1 + 1])  # compiled argmax (rim_kernel)
    if i < 0:
        return None
    w = x1 - x0 + 1
    return x0 + i % w, y0 + i // w


def is_object(blob: Blob | None, min_significance: float, min_isolation: float) -> TypeGuard[Blob]:
    """Significant and isolated (module docstring)."""
    if blob is None or not blob.prominence > 0:
        return False
    return blob.significance >= min_significance and blob.prominence >= min_isolation * max(
        blob.contrast, 0.0
    )


def find_objects(
    frame: np.ndarray,
    centre: tuple[int, int],
    half_px: int,
    *,
    config: BlobConfig,
    min_significance: float,
    min_isolation: float,
    size_px: int = 1,
    seed_sigma: float = 2.0,
    max_analysed: int = 12,
    seeds: tuple[tuple[int, int], ...] = (),
    min_contrast: float = 0.0,
) -> list[Blob]:
    """Objects in the square of half-size ``half_px`` around ``centre`` (module docstring),
    nearest the centre first (distance from the centre to the object's core box).
    ``min_contrast`` (DN): groups that stand less than half of it above the local mean are
    not analysed (a lost drone of known prominence)."""
    cx, cy = centre
    box = clip_box((cx - half_px, cy - half_px, cx + half_px, cy + half_px), frame.shape)
    if box is None:
        return []
    x0, y0, x1, y1 = box
    win = np.asarray(frame[y0 : y1 + 1, x0 : x1 + 1], np.float32)
    finite = np.isfinite(win)
    if not finite.any():
        return []
    if not finite.all():
        win = np.where(finite, win, np.float32(np.nanmin(win)))
    sigma = max(robust_sigma(win), 1e-6)
    k = min(max(7, 3 * int(size_px) + 1) | 1, 2 * max(win.shape) + 1)
    excess = win - cv2.blur(win, (k, k))
    high = (excess >= seed_sigma * sigma).astype(np.uint8)
    found: list[tuple[int, int]] = list(seeds)
    n, labels, stats, cents = cv2.connectedComponentsWithStats(high, connectivity=8)
    if n > 1:
        # A group that stands less than 0.6 x min_significance sigma (3 sigma for 5) over its
        # local mean cannot hold an object that significant: the noise's own groups go.
        index = np.arange(1, n)
        floor = max(0.5 * min_contrast, 0.6 * min_significance * sigma)
        keep = index[ndimage.maximum(excess, labels, index) >= floor]
        # Groups far larger than the object (a treeline's edge, a cloud's) come last.
        d = np.hypot(cents[keep, 0] + x0 - cx, cents[keep, 1] + y0 - cy)
        large = np.maximum(stats[keep, 2], stats[keep, 3]) > 4 * size_px + 8
        where = ndimage.maximum_position(win, labels, keep[np.lexsort((d, large))][:max_analysed])
        found += [(x0 + int(px), y0 + int(py)) for py, px in where]
    out: dict[tuple[int, int], Blob] = {}
    for seed in found:
        blob = analyse_blob(frame, seed, config, min_half_px=size_px)
        if is_object(blob, min_significance, min_isolation):
            out.setdefault((blob.peak_x, blob.peak_y), blob)
    return sorted(out.values(), key=lambda b: (box_distance(b.core_box, centre), -b.prominence))


def box_distance(box: Box, xy: tuple[float, float]) -> float:
    """Euclidean distance from a point to a box (0 inside it)."""
    x0, y0, x1, y1 = box
    x, y = xy
    dx = max(x0 - x, 0.0, x - x1)
    dy = max(y0 - y, 0.0, y - y1)
    return math.hypot(dx, dy)
