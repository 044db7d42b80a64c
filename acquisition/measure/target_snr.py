"""Target-aware Eq. (4): the background measured where it is background.

Paper Eq. (4) takes the background from the 24 rim pixels of the 7x7 box centred on the peak,
which assumes the target lies within the box's 3x3 core and 5x5 guard (section 5). A resolved
drone (any drone at close range, or a bright one in 8-bit AGC'd video) puts its own pixels on
that rim: the rim mean rises, its std grows with the signal, and the SNR reads 1-3 where the
truth is hundreds. The paper's second method, a clear-sky region chosen by the operator, "did
not differ significantly" where both apply (section 5).

The rule (:func:`background_rule`), per frame, from the target's segmented extent
(:class:`snrmon.acquisition.measure.blob.Blob`: every pixel connected to the target that carries
more than 3 sigma of its signal):

- ``rect``: the operator's clear-sky rectangle, when one is configured (always preferred: the
  operator chose it).
- ``rim``: the extent lies within the 5x5 guard around the peak (Chebyshev distance <= box_px//2
  - 1). The target does not reach the rim: Eq. (4) exactly as :func:`snrmon.acquisition.measure.
  peak_snr.peak_snr_with` computes it, bit for bit.
- ``extent_rim``: otherwise. The background is the one-pixel rim of the rectangle made of the
  extent's box grown by ``guard_px`` (2) guard pixels and the rim itself, so it lies
  ``guard_px + 1`` pixels or more outside every pixel above 3 sigma: the same construction as
  Eq. (4)'s box (core, guard ring, rim), scaled to the target. The peak is the target's
  brightest pixel (first in row-major order among equals); mean, std (``ddof``), detrend and the
  contamination test (with the rectangle's longer side - 1 as the gradient's extent) are those of
  Eq. (4) (:func:`snrmon.acquisition.measure.background.background_stats`).

Conventions: x = column, y = row, zero-based; rectangles ``(x0, y0, x1, y1)`` both included.
"""

from __future__ import annotations

import dataclasses
import functools
import math

import numpy as np

from snrmon.acquisition.measure.background import Rect, background_stats
from snrmon.acquisition.measure.blob import Blob
from snrmon.acquisition.measure.contamination import is_contaminated
from snrmon.acquisition.measure.peak_snr import (
    BACKGROUND_EXTENT,
    BACKGROUND_RECT,
    BACKGROUND_RIM,
    FLAG_EDGE,
    FLAG_RIM_CONTAMINATED,
    FLAG_SATURATED,
    FLAG_UNDEFINED,
    PeakSnr,
    PeakSnrConfig,
    peak_snr_with,
    result_with,
    saturation_level,
)
from snrmon.acquisition.measure.rim_kernel import (
    pixel_kind,
    rim_background,
    rim_excesses,
    wing_decision,
)
from snrmon.acquisition.stage_clock import EQ4, enter


def background_rule(blob: Blob, cfg: PeakSnrConfig) -> str:
    """Which background a frame of this target is measured against (module docstring)."""
    if cfg.background is not None:
        return BACKGROUND_RECT
    if blob.extent_within(cfg.box_px // 2 - 1):
        return BACKGROUND_RIM
    return BACKGROUND_EXTENT


def extent_rim_rect(blob: Blob, guard_px: int) -> Rect:
    """The rectangle whose one-pixel rim is the ``extent_rim`` background."""
    x0, y0, x1, y1 = blob.extent_box
    g = guard_px + 1
    return (x0 - g, y0 - g, x1 + g, y1 + g)


def _rim_mean(pixels: np.ndarray, rect: Rect) -> tuple[float, int] | None:
    """(mean, pixel count) of the one-pixel rim of ``rect``; None when it leaves the image."""
    x0, y0, x1, y1 = rect
    rows, cols = pixels.shape
    if x0 < 0 or y0 < 0 or x1 >= cols or y1 >= rows or x1 - x0 < 2 or y1 - y0 < 2:
        return None
    outer = pixels[y0 : y1 + 1, x0 : x1 + 1].sum(dtype=np.float64)
    inner = pixels[y0 + 1 : y1, x0 + 1 : x1].sum(dtype=np.float64)
    n = (x1 - x0 + 1) * (y1 - y0 + 1) - (x1 - x0 - 1) * (y1 - y0 - 1)
    return float(outer - inner) / n, n


def rim_excess(pixels: np.ndarray, rect: Rect, sigma: float, k: int) -> float:
    """How much brighter the rim of ``rect`` grown by ``k`` px is than the rim 2 px farther
    out, in units of the noise of that difference (sigma x sqrt(1/n1 + 1/n2)); NaN where a
    rim leaves the image. A plane (a sky gradient) adds the same to two rims centred on the
    same point, so only light falling off outwards (PSF wings) shows."""
    x0, y0, x1, y1 = rect
    here = _rim_mean(pixels, (x0 - k, y0 - k, x1 + k, y1 + k))
    far = _rim_mean(pixels, (x0 - k - 2, y0 - k - 2, x1 + k + 2, y1 + k + 2))
    if here is None or far is None or not sigma > 0:
        return math.nan
    return (here[0] - far[0]) / (sigma * math.sqrt(1.0 / here[1] + 1.0 / far[1]))


def _excesses(pixels: np.ndarray, rect: Rect, sigma: float, most: int) -> np.ndarray | None:
    """:func:`rim_excess` for k = 0..most in one compiled pass over the pixels around the
    largest rim (:func:`snrmon.acquisition.measure.rim_kernel.rim_excesses`); None when its sums are
    not provably exact (the caller sums with NumPy)."""
    rows, cols = pixels.shape
    x0, y0, x1, y1 = rect
    g = most + 2
    ry0, ry1 = max(y0 - g, 0), min(y1 + g, rows - 1)
    rx0, rx1 = max(x0 - g, 0), min(x1 + g, cols - 1)
    if ry1 < ry0 or rx1 < rx0:
        return None
    region = pixels[ry0 : ry1 + 1, rx0 : rx1 + 1]
    kind = pixel_kind(region.dtype)
    exact, out = rim_excesses(region, ry0, rx0, rows, cols, rect, float(sigma), most, kind)
    return out if exact else None


FIRST_STEPS = 2  # the wing profile's first look: growths 0..2 (a 7x7 rim: 15 x 15 pixels)


class WingProfile:
    """Where the background rim must lie to be clear of the target's PSF wings.

    Wings can carry less than 3 sigma per pixel (so they are not extent) and still lift a
    7x7 rim's mean and, more, its std: on the model's real MWIR PSF, 0.5-1 sigma per pixel 3 px
    from a distant drone read Eq. (4) 10 % low. One frame cannot see that; the track's recent
    frames can. For each k the rim grown by k px is compared with the rim 2 px farther out
    (:func:`rim_excess`); the mean of that excess over the last ``frames`` (25) frames is
    significant above ``z`` / sqrt(n) (``z`` = 4: 3e-5 false alarms per decision). The
    background moves out by the smallest k that is not significant (at most ``most`` = 8);
    until ``min_frames`` (5) are known, each frame is judged on its own at ``z``.
    """

    def __init__(self, frames: int = 25, most: int = 8, z: float = 4.0, min_frames: int = 5):
        self.frames = frames
        self.most = most
        self.z = z
        self.min_frames = min_frames
        # The last ``frames`` frames' excesses (NaN: not measured), a ring from row _first on.
        self._recent = np.full((frames, most + 1), math.nan)
        self._first = 0
        self._n = 0

    def _append(self) -> int:
        """A new frame's row (all NaN), the oldest dropped when the ring is full."""
        if self._n < self.frames:
            row = (self._first + self._n) % self.frames
            self._n += 1
        else:
            row = self._first
            self._first = (self._first + 1) % self.frames
        self._recent[row] = math.nan
        return row

    def growth(self, pixels: np.ndarray, rect: Rect, sigma: float) -> int:
        """Add this frame's excess; how many pixels the rim of ``rect`` moves out. Only the
        steps the decision reaches are measured (NaN for the others: left out of the means)."""
        row = self._append()
        # Compiled: the same decision on the same numbers, first on the steps most frames
        # stop at (the pixels within FIRST_STEPS + 2 of the rim), then on all of them.
        for steps in (min(FIRST_STEPS, self.most), self.most):
            excess = _excesses(pixels, rect, sigma, steps)
            if excess is None:
                break
            k = wing_decision(
                self._recent, self._first, self._n, row, excess, self.z, self.min_frames
            )
            if k >= 0:
                return k
        for k in range(self.most + 1):
            now = rim_excess(pixels, rect, sigma, k)
            self._recent[row, k] = now
            if not math.isfinite(now):
                return k  # the rims leave the image: no farther
            column = self._recent[(self._first + np.arange(self._n)) % self.frames, k].tolist()
            past = [e for e in column if math.isfinite(e)]
            if len(past) < self.min_frames:
                if now <= self.z:
                    return k
            elif sum(past) / len(past) <= self.z / math.sqrt(len(past)):
                return k
        return self.most

    def clear(self) -> None:
        self._first = self._n = 0

    def _rows(self) -> list[list[float]]:
        order = (self._first + np.arange(self._n)) % self.frames
        return self._recent[order].tolist()

    def snapshot(self) -> dict:
        return {"recent": [[None if math.isnan(v) else v for v in e] for e in self._rows()]}

    def restore(self, state: dict) -> None:
        rows = state["recent"][-self.frames :]
        self._first, self._n = 0, len(rows)
        for i, e in enumerate(rows):
            self._recent[i] = [math.nan if v is None else float(v) for v in e]


@functools.lru_cache(maxsize=256)
def _rect_rim(width: int, height: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(mask, dy, dx) of the rim of a width x height rectangle, offsets about its centre
    (row-major; zero sum and zero cross sum, as ``background_stats`` needs)."""
    mask = np.zeros((height, width), bool)
    mask[0, :] = mask[-1, :] = True
    mask[:, 0] = mask[:, -1] = True
    yy, xx = np.nonzero(mask)
    dy = yy - (height - 1) / 2.0
    dx = xx - (width - 1) / 2.0
    for a in (mask, dy, dx):
        a.flags.writeable = False
    return mask, dy, dx


def measure_target(
    pixels: np.ndarray,
    blob: Blob,
    cfg: PeakSnrConfig,
    *,
    guard_px: int = 2,
    rect: Rect | None = None,
    reference_noise: float | None = None,
) -> PeakSnr:
    """Eq. (4) of the segmented target ``blob`` against the ``extent_rim`` background (the rim
    of ``rect``, by default :func:`extent_rim_rect`), or the configured clear-sky rectangle
    (module docstring). ``reference_noise`` (DN): the recent sky noise of the
    ``rim_contaminated`` test (None skips it)."""
    rows, cols = pixels.shape
    px, py = blob.peak_x, blob.peak_y
    peak = float(pixels[py, px])
    bits: set[str] = set()
    n_rim = 0
    if cfg.background is not None:
        method = BACKGROUND_RECT
        x0, y0, x1, y1 = cfg.background
        if x0 < 0 or y0 < 0 or x1 >= cols or y1 >= rows:
            raise ValueError(
                f"background rectangle {cfg.background} leaves the {cols}x{rows} image"
            )
        dy, dx = cfg.offsets
        values = pixels[y0 : y1 + 1, x0 : x1 + 1].reshape(1, -1).astype(np.float64)
        extent = cfg.extent_px
    else:
        method = BACKGROUND_EXTENT
        x0, y0, x1, y1 = extent_rim_rect(blob, guard_px) if rect is None else rect
        width, height = x1 - x0 + 1, y1 - y0 + 1
        extent = max(width, height) - 1
        if x0 < 0 or y0 < 0 or x1 >= cols or y1 >= rows:
            bits |= {FLAG_EDGE, FLAG_UNDEFINED}
            values = None
        elif width >= 3 and height >= 3 and 2 * (width + height) - 4 > cfg.ddof:
            values = None  # compiled: background_stats of the rim, bit for bit (rim_kernel)
            region = pixels[y0 : y1 + 1, x0 : x1 + 1]
            bg_mean, bg_std, gradient, n_rim = rim_background(region, cfg.detrend, cfg.ddof)
        else:
            mask, dy, dx = _rect_rim(width, height)
            values = pixels[y0 : y1 + 1, x0 : x1 + 1][mask].reshape(1, -1).astype(np.float64)
    n_pixels: int | None = n_rim or None
    if values is not None:
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            mean, std, grad = background_stats(values, dy, dx, detrend=cfg.detrend, ddof=cfg.ddof)
        bg_mean, bg_std, gradient = float(mean[0]), float(std[0]), float(grad[0])
        n_pixels = None if method == BACKGROUND_RECT else values.shape[1]
    elif not n_rim:
        bg_mean = bg_std = gradient = math.nan
    if not (math.isfinite(bg_std) and bg_std != 0 and math.isfinite(peak)):
        bits.add(FLAG_UNDEFINED)
    snr = math.nan if FLAG_UNDEFINED in bits else (peak - bg_mean) / bg_std
    sat = saturation_level(cfg, pixels.dtype)
    if sat is not None and math.isfinite(peak) and peak >= sat:
        bits.add(FLAG_SATURATED)
    if FLAG_UNDEFINED not in bits and is_contaminated(
        bg_std, gradient, reference_noise, cfg, extent_px=extent, n_pixels=n_pixels
    ):
        bits.add(FLAG_RIM_CONTAMINATED)
    w, h = blob.extent_size
    return PeakSnr(
        px,
        py,
        peak if math.isfinite(peak) else math.nan,
        bg_mean,
        bg_std,
        snr,
        frozenset(bits),
        method,
        w,
        h,
    )


class TargetMeter:
    """Eq. (4) of a tracked object with the background :func:`background_rule` picks.

    ``measure`` is :func:`snrmon.acquisition.measure.peak_snr.peak_snr_with` with the search window
    set per call (one configuration per size, built once: each keeps its cached offsets).
    ``measure_object``: the extent within the 5x5 guard (or a rectangle configured) -> Eq. (4)
    in the search window centred on ``at``, bit-identical to the fixed-point measurement; if
    that window's brightest pixel is not the object's peak, the same in a ``2 gate_px + 1``
    window, else at the peak itself (a 1-pixel window). Larger -> :func:`measure_target`.
    """

    def __init__(
        self, config: PeakSnrConfig, *, gate_px: int, guard_px: int, wing_px: int = 8
    ) -> None:
        self.config = config
        self.gate_px = gate_px
        self.guard_px = guard_px
        self.wings = WingProfile(most=wing_px)
        self._configs: dict[int, PeakSnrConfig] = {config.search_px: config}

    def measure(self, pixels, at, search_px: int, reference_noise) -> PeakSnr:
        running = enter(EQ4)  # the stages of a live frame (snrmon.acquisition.stage_clock)
        cfg = self._configs.get(search_px)
        if cfg is None:
            cfg = self._configs[search_px] = dataclasses.replace(self.config, search_px=search_px)
        m = peak_snr_with(pixels, at, cfg, reference_noise=reference_noise)
        enter(running)
        return m

    def measure_object(
        self, pixels, blob: Blob, at, reference_noise
    ) -> tuple[PeakSnr, tuple[int, int], int]:
        """(measurement, centre of the window it was taken in, window size)."""
        running = enter(EQ4)
        out = self._measure_object(pixels, blob, at, reference_noise)
        enter(running)
        return out

    def _measure_object(
        self, pixels, blob: Blob, at, reference_noise
    ) -> tuple[PeakSnr, tuple[int, int], int]:
        cfg = self.config
        peak = (blob.peak_x, blob.peak_y)
        w, h = blob.extent_size
        rule = background_rule(blob, cfg)
        rect = None
        if rule == BACKGROUND_RIM:
            r = cfg.box_px // 2
            base = (peak[0] - r, peak[1] - r, peak[0] + r, peak[1] + r)
            k = self.wings.growth(pixels, base, blob.sigma)
            if k:  # the 7x7 rim holds the target's PSF wings: the background moves out
                rule = BACKGROUND_EXTENT
                rect = (peak[0] - r - k, peak[1] - r - k, peak[0] + r + k, peak[1] + r + k)
        elif rule == BACKGROUND_EXTENT:
            x0, y0, x1, y1 = extent_rim_rect(blob, self.guard_px)
            k = self.wings.growth(pixels, (x0, y0, x1, y1), blob.sigma)
            rect = (x0 - k, y0 - k, x1 + k, y1 + k)
        if rule != BACKGROUND_EXTENT:
            for size in (cfg.search_px, 2 * self.gate_px + 1):
                m = self.measure(pixels, at, size, reference_noise)
                if (m.peak_x, m.peak_y) == peak:
                    break
            else:
                at, size = peak, 1
                m = self.measure(pixels, at, size, reference_noise)
            return result_with(m, extent_px=(w, h)), at, size
        m = measure_target(
            pixels, blob, cfg, guard_px=self.guard_px, rect=rect, reference_noise=reference_noise
        )
        x0, y0, x1, y1 = blob.window
        return m, peak, max(x1 - x0, y1 - y0) + 1
