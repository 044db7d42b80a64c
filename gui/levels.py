"""Robust display levels for an infrared frame (display only; never a measurement).

A single hot pixel or the sun's glint must not flatten the sky into one grey, so the levels are
percentiles rather than the minimum and maximum; they are taken on a strided view (every 5th row
and column of a 1280 x 720 frame, ~37 000 pixels) so the cost stays well under a millisecond.

The percentiles of a noisy sky move by a few DN from frame to frame; :func:`levels_moved` tells
the view when new levels differ enough from the shown ones to be worth applying, so the levels
(and the histogram control that draws them) are not redrawn for changes no one can see.
"""

from __future__ import annotations

import math

import numpy as np

DEFAULT_PERCENTILES = (0.5, 99.9)
DEFAULT_LEVELS_TOLERANCE = 0.03  # of the shown window: ~8 of 256 grey steps


def robust_levels(
    pixels: np.ndarray,
    percentiles: tuple[float, float] = DEFAULT_PERCENTILES,
    max_samples: int = 40_000,
) -> tuple[float, float]:
    """(low, high) display levels: ``percentiles`` of a strided sample of ``pixels``.

    The stride keeps at most about ``max_samples`` pixels. NaNs are ignored. ``high`` is always
    above ``low`` (a flat frame gets a one-DN window) so a levels control never divides by zero.
    """
    lo_p, hi_p = percentiles
    if not 0.0 <= lo_p < hi_p <= 100.0:
        raise ValueError(f"percentiles must satisfy 0 <= low < high <= 100, got {percentiles}")
    if pixels.size == 0:
        raise ValueError("cannot take display levels of an empty frame")
    step = max(1, int(np.ceil(np.sqrt(pixels.size / max_samples))))
    sample = pixels[::step, ::step] if pixels.ndim == 2 else pixels.ravel()[:: step * step]
    sample = np.asarray(sample, dtype=np.float32)
    if np.issubdtype(pixels.dtype, np.floating):
        sample = sample[np.isfinite(sample)]
        if sample.size == 0:
            return 0.0, 1.0
    lo, hi = np.percentile(sample, [lo_p, hi_p])
    lo, hi = float(lo), float(hi)
    if hi <= lo:
        hi = lo + 1.0
    return lo, hi


def levels_moved(
    shown: tuple[float, float],
    new: tuple[float, float],
    tolerance: float = DEFAULT_LEVELS_TOLERANCE,
) -> bool:
    """Whether ``new`` (low, high) levels differ from the ``shown`` ones by more than
    ``tolerance`` times the shown window (high - low) at either end."""
    if tolerance < 0.0:
        raise ValueError(f"levels tolerance must be >= 0, got {tolerance}")
    lo, hi = shown
    span = hi - lo
    if not span > 0.0:  # a degenerate or NaN window: anything is better
        return True
    return abs(new[0] - lo) > tolerance * span or abs(new[1] - hi) > tolerance * span


class AutoLevels:
    """The display levels of a stream of frames: the operator's while auto-levels is off; else
    :func:`robust_levels` of every ``every``-th frame, applied only when they moved beyond the
    dead band (:func:`levels_moved`) of those in use, or at once after auto-levels is asked for
    again. Plain code for the display's worker thread (the percentiles never run on the GUI's)."""

    def __init__(self, every: int = 3) -> None:
        self.every = every  # percentiles on every 3rd frame: plenty for a display
        self.levels: tuple[float, float] | None = None  # in use
        self._countdown = 0  # frames until the next percentiles (0: on the next frame)
        self._generation: int | None = None  # of the auto-levels request the levels are from

    def levels_of(
        self,
        pixels: np.ndarray,
        auto: bool,
        manual: tuple[float, float],
        generation: int,
    ) -> tuple[float, float]:
        """The levels (low, high) to show ``pixels`` with: ``manual`` unless ``auto``; with
        ``auto``, a new ``generation`` (auto-levels asked for again) takes the next percentiles
        whatever they are."""
        if not auto:
            self.levels = (float(manual[0]), float(manual[1]))
            return self.levels
        current = self.levels
        if current is None or generation != self._generation:
            current = robust_levels(pixels)
            self._generation = generation
            self._countdown = self.every
        elif self._countdown <= 0:
            self._countdown = self.every
            new = robust_levels(pixels)
            if levels_moved(current, new):
                current = new
        self._countdown -= 1
        self.levels = current
        return current


HISTOGRAM_SIDE_PX = 200  # the histogram samples about this many rows and columns, as pyqtgraph
HISTOGRAM_BINS = 500  # at most this many bins; integer DN never split between two


def display_histogram(pixels: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """The levels control's histogram of a frame: (left edges of the bins in DN, counts), as
    pyqtgraph's ``ImageItem.getHistogram`` makes it (every ``ceil(rows / 200)``-th row and
    ``ceil(columns / 200)``-th column; integer frames in bins of a whole number of DN, at most
    about :data:`HISTOGRAM_BINS` of them; float frames in 500 bins, NaN left out). None for an
    empty or all-NaN frame. For the display's worker thread: a statistic is never taken on the
    GUI's."""
    if pixels.ndim != 2 or pixels.size == 0:
        return None
    step_r = max(1, math.ceil(pixels.shape[0] / HISTOGRAM_SIDE_PX))
    step_c = max(1, math.ceil(pixels.shape[1] / HISTOGRAM_SIDE_PX))
    sample = pixels[::step_r, ::step_c]
    if sample.dtype.kind == "f":
        sample = sample[np.isfinite(sample)]
        if sample.size == 0:
            return None
    lo, hi = sample.min().item(), sample.max().item()
    if sample.dtype.kind in "ui":
        width = max(1, math.ceil((hi - lo) / HISTOGRAM_BINS))
        counts = np.bincount((sample.ravel() - lo) // width)
        return lo + width * np.arange(counts.size, dtype=np.float64), counts
    counts, edges = np.histogram(sample, bins=np.linspace(lo, hi if hi > lo else lo + 1, 500))
    return edges[:-1], counts


def histogram_range(
    lo: float, hi: float, shown: tuple[float, float] | None = None
) -> tuple[float, float]:
    """The DN range the levels control shows a histogram of ``lo`` .. ``hi`` over.

    A noisy sky's minimum and maximum move at every frame and a new range re-typesets the
    control's axis (~2 ms of the GUI thread), so the range does not follow them: the ``shown``
    range is kept while it holds the data and the data fill at least half of it; else the data
    are widened by a step on each side, the step a whole 1, 2 or 5 times a power of ten of at
    least a tenth of the span, and rounded out to whole steps."""
    if shown is not None:
        s_lo, s_hi = shown
        if s_lo <= lo and hi <= s_hi and (hi - lo) >= 0.5 * (s_hi - s_lo):
            return shown
    span = max(hi - lo, 1.0)
    power = 10.0 ** math.floor(math.log10(span / 10.0)) if span >= 10.0 else 1.0
    step = next(m * power for m in (1.0, 2.0, 5.0, 10.0) if m * power >= span / 10.0)
    return math.floor(lo / step) * step - step, math.ceil(hi / step) * step + step
