"""Background pixels of Eq. (4): the box rim, the clear-sky rectangle, the plane detrend.

Paper section 5: the background of the peak-pixel SNR is either the 24 rim pixels of the 7x7 box
centred on the peak, or an operator-chosen clear-sky region; the background pixels may be detrended
(a least-squares plane removed) before their standard deviation is taken (section 6: "~10%
reduction of the total noise with detrending").

Conventions: x is the column, y the row, zero-based, integers at pixel centres. A rectangle is
``(x0, y0, x1, y1)`` with BOTH corners INCLUDED (``x0..x1`` columns, ``y0..y1`` rows).

Every statistic here works on a 2-D array ``(N, n)`` (N frames, n background pixels each) so the
per-frame path (N = 1) and the stack path run the very same reductions and agree bit for bit.
"""

from __future__ import annotations

import functools
import math

import numpy as np

Rect = tuple[int, int, int, int]


def rim_offsets(box_px: int) -> tuple[np.ndarray, np.ndarray]:
    """(dy, dx) of the rim pixels of an odd ``box_px`` square box, relative to its centre.

    The rim is the outer ring of the box (24 pixels for 7x7: 4*(box_px-1)), listed in row-major
    order. ``box_px`` must be odd and >= 3. The arrays are shared (cached): do not modify them.
    """
    if box_px < 3 or box_px % 2 != 1:
        raise ValueError(f"box size must be an odd integer >= 3, got {box_px}")
    return _rim_offsets(int(box_px))


@functools.lru_cache(maxsize=16)
def _rim_offsets(box_px: int) -> tuple[np.ndarray, np.ndarray]:
    # Called twice per measured frame (validation and the rim itself): built once per size.
    h = box_px // 2
    dy, dx = np.mgrid[-h : h + 1, -h : h + 1]
    on_rim = (np.abs(dy) == h) | (np.abs(dx) == h)
    dy, dx = dy[on_rim].astype(np.intp), dx[on_rim].astype(np.intp)
    dy.flags.writeable = False
    dx.flags.writeable = False
    return dy, dx


def parse_rect(text: str) -> Rect:
    """``"X0,Y0,X1,Y1"`` -> an inclusive rectangle; one clear ValueError naming the text."""
    parts = [p.strip() for p in text.split(",")]
    try:
        if len(parts) != 4:
            raise ValueError
        x0, y0, x1, y1 = (int(p) for p in parts)
    except ValueError:
        raise ValueError(
            f"background rectangle must be X0,Y0,X1,Y1 (four integers), got {text!r}"
        ) from None
    return (x0, y0, x1, y1)


def validate_rect(rect: Rect, shape: tuple[int, int], *, min_pixels: int = 2) -> Rect:
    """Check an inclusive rectangle lies in an image of ``shape`` = (rows, columns)."""
    x0, y0, x1, y1 = (int(v) for v in rect)
    rows, cols = shape
    if x1 < x0 or y1 < y0:
        raise ValueError(f"background rectangle {rect} has X1 < X0 or Y1 < Y0")
    if x0 < 0 or y0 < 0 or x1 >= cols or y1 >= rows:
        raise ValueError(
            f"background rectangle {rect} leaves the {cols}x{rows} image "
            f"(x must be 0..{cols - 1}, y 0..{rows - 1})"
        )
    if (x1 - x0 + 1) * (y1 - y0 + 1) < min_pixels:
        raise ValueError(f"background rectangle {rect} holds fewer than {min_pixels} pixels")
    return (x0, y0, x1, y1)


def rect_offsets(rect: Rect) -> tuple[np.ndarray, np.ndarray]:
    """(dy, dx) of every pixel of an inclusive rectangle, row-major, relative to its centre.

    Centred coordinates make the constant, x and y terms of the plane fit orthogonal, so the
    least-squares plane has a closed form (see :func:`background_stats`).
    """
    x0, y0, x1, y1 = rect
    dy, dx = np.mgrid[y0 : y1 + 1, x0 : x1 + 1]
    return (dy - (y0 + y1) / 2.0).ravel(), (dx - (x0 + x1) / 2.0).ravel()


def background_stats(
    values: np.ndarray,
    dy: np.ndarray,
    dx: np.ndarray,
    *,
    detrend: bool = False,
    ddof: int = 1,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean, standard deviation and plane-gradient magnitude of background pixels.

    Args:
        values: ``(N, n)`` float64 background pixels of N frames.
        dy, dx: ``(n,)`` pixel offsets with zero sum and zero cross sum (a rim or a full
            rectangle about its centre), for which the least-squares plane is
            ``mean + gx*dx + gy*dy`` with ``gx = sum(v*dx)/sum(dx^2)`` (and likewise gy).
        detrend: remove that plane before the std (paper section 6); the mean is the plain mean
            either way, which is also the plane's value at the centre.
        ddof: delta degrees of freedom of the std: 1 = sample std (MATLAB ``std``), 0 = numpy's
            default. With ``detrend`` the std is of the residuals with the same ``ddof`` (the
            paper's "remove the plane, then std"; an unbiased variance would use n - 3).

    Returns:
        ``(mean, std, gradient)`` each ``(N,)``; ``gradient`` is |(gx, gy)| in DN per pixel.
    """
    n = values.shape[1]
    mean, dev, gx, gy, dxf, dyf = _plane_fit(values, dy, dx)
    if detrend:
        dev = dev - gx[:, None] * dxf - gy[:, None] * dyf
    std = np.sqrt((dev * dev).sum(axis=1) / (n - ddof))
    return mean, std, np.hypot(gx, gy)


def detrended(values: np.ndarray, dy: np.ndarray, dx: np.ndarray) -> np.ndarray:
    """``values`` (N, n) with their least-squares plane (mean and x/y slopes) removed."""
    _, dev, gx, gy, dxf, dyf = _plane_fit(values, dy, dx)
    return dev - gx[:, None] * dxf - gy[:, None] * dyf


def _plane_fit(values: np.ndarray, dy: np.ndarray, dx: np.ndarray):
    """Mean, deviations from it, and the plane slopes gx, gy (offsets about the centre: the
    normal equations decouple), with the offsets as float64."""
    mean = values.sum(axis=1) / values.shape[1]
    dev = values - mean[:, None]
    dxf = dx.astype(np.float64)
    dyf = dy.astype(np.float64)
    sxx = float((dxf * dxf).sum())
    syy = float((dyf * dyf).sum())
    gx = (dev * dxf).sum(axis=1) / sxx if sxx > 0 else np.zeros_like(mean)
    gy = (dev * dyf).sum(axis=1) / syy if syy > 0 else np.zeros_like(mean)
    return mean, dev, gx, gy, dxf, dyf


CLEAR_MARGIN_PX = 20
"""Pixels kept between the target's peak (plus half its segmented extent) and a background region
meant to be clear of it: the drone's blur and its Eq. (4) box stay out (the half width of the
section 6 noise square around the track)."""


def target_box(
    shape: tuple[int, int],
    points_xy,
    *,
    margin_px: int = CLEAR_MARGIN_PX,
    half_extent_px: int = 0,
) -> Rect:
    """The inclusive rectangle holding every ``(x, y)`` of ``points_xy`` widened by
    ``margin_px + half_extent_px`` on each side, clipped to an image of ``shape`` (rows,
    columns): where the target was."""
    pts = np.asarray(points_xy, dtype=np.int64).reshape(-1, 2)
    if pts.size == 0:
        raise ValueError("a target box needs at least one position")
    pad = int(margin_px) + int(half_extent_px)
    rows, cols = shape
    x0, y0 = pts.min(axis=0) - pad
    x1, y1 = pts.max(axis=0) + pad
    return (max(int(x0), 0), max(int(y0), 0), min(int(x1), cols - 1), min(int(y1), rows - 1))


def clear_region(
    shape: tuple[int, int],
    exclude: Rect,
    *,
    min_side: int = 2,
    max_pixels: int | None = None,
) -> Rect | None:
    """The largest rectangle of an image of ``shape`` (rows, columns) that holds no pixel of
    ``exclude``: the largest of the full-width bands above and below it and the full-height
    bands left and right of it (any rectangle clear of ``exclude`` lies in one of them, so none
    is larger). Ties: above, below, left, right. None when no band is ``min_side`` pixels in
    both directions.

    ``max_pixels``: crop the band to at most that many pixels, keeping the part nearest the
    target (the rows or columns next to ``exclude``, centred on it across the band)."""
    rows, cols = shape
    x0, y0, x1, y1 = exclude
    bands = [
        (0, 0, cols - 1, y0 - 1),  # above
        (0, y1 + 1, cols - 1, rows - 1),  # below
        (0, 0, x0 - 1, rows - 1),  # left
        (x1 + 1, 0, cols - 1, rows - 1),  # right
    ]

    def size(r: Rect) -> tuple[int, int]:
        return r[2] - r[0] + 1, r[3] - r[1] + 1

    usable = [b for b in bands if min(size(b)) >= min_side]
    if not usable:
        return None
    best = max(usable, key=lambda b: size(b)[0] * size(b)[1])  # max keeps the first of ties
    w, h = size(best)
    if max_pixels is None or w * h <= max_pixels:
        return best
    # the shorter side whole up to a square's, the longer as far as the budget allows
    side = max(min_side, math.isqrt(max_pixels))
    if h <= w:
        keep_h = min(h, side)
        keep_w = min(w, max(min_side, max_pixels // keep_h))
    else:
        keep_w = min(w, side)
        keep_h = min(h, max(min_side, max_pixels // keep_w))
    index = bands.index(best)
    if index < 2:  # above or below: the rows next to the target, the columns centred on it
        left = min(max((x0 + x1) // 2 - keep_w // 2, 0), cols - keep_w)
        top = best[3] - keep_h + 1 if index == 0 else best[1]
    else:  # left or right: the columns next to the target, the rows centred on it
        top = min(max((y0 + y1) // 2 - keep_h // 2, 0), rows - keep_h)
        left = best[2] - keep_w + 1 if index == 2 else best[0]
    return (left, top, left + keep_w - 1, top + keep_h - 1)


def overlaps(a: Rect, b: Rect) -> bool:
    """Whether two inclusive rectangles share a pixel."""
    return not (a[2] < b[0] or b[2] < a[0] or a[3] < b[1] or b[3] < a[1])
