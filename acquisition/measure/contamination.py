"""The ``rim_contaminated`` test of Eq. (4)'s background (a cloud edge or the drone itself in the
rim, paper section 6) and the recent-noise reference it compares against, in DN.

A frame is contaminated when its background std exceeds ``contamination_std_factor`` (2) times
the recent noise, or its fitted plane's gradient across the background's extent exceeds
``contamination_gradient_factor`` (3) times it. The recent noise is the median background std of
the last accepted frames, so one bright frame cannot move it.
"""

from __future__ import annotations

import bisect
import math
from collections import deque

RIM_PIXELS = 24  # the 7x7 rim the std factor is stated for


def std_factor(cfg, n_pixels: int | None) -> float:
    """The std threshold for a background of ``n_pixels`` (None: the configured factor): the
    same significance as ``contamination_std_factor`` on the 24-pixel rim. The std of n
    pixels of white noise scatters by 1/sqrt(2 (n - 1)), so the excess over 1 scales by
    sqrt(23 / (n - 1)): 2.0 on the 7x7 rim, 1.57 on a 72-pixel extent rim."""
    f = cfg.contamination_std_factor
    if n_pixels is None or n_pixels <= RIM_PIXELS:
        return f
    return 1.0 + (f - 1.0) * math.sqrt((RIM_PIXELS - 1) / (n_pixels - 1))


def is_contaminated(
    bg_std: float,
    gradient: float,
    reference: float | None,
    cfg,
    extent_px: int | None = None,
    n_pixels: int | None = None,
) -> bool:
    """The ``rim_contaminated`` test of one frame against a recent-noise reference (DN);
    ``extent_px``: the background's extent for the gradient term (default ``cfg.extent_px``);
    ``n_pixels``: a background larger than the rim gets the std threshold of the same
    significance (:func:`std_factor`; None keeps the configured factor)."""
    if reference is None or not math.isfinite(bg_std):
        return False
    extent = cfg.extent_px if extent_px is None else extent_px
    return bool(
        bg_std > std_factor(cfg, n_pixels) * reference
        or gradient * extent > cfg.contamination_gradient_factor * reference
    )


class NoiseReference:
    """The recent noise for the ``rim_contaminated`` test: the median background std of the last
    ``frames`` accepted frames (no flag of
    :data:`snrmon.acquisition.measure.peak_snr.RUNNING_EXCLUDED`); None
    until ``min_frames``.

    A genuinely changed sky must not stay "contaminated" forever: after ``frames`` consecutive
    contaminated frames the history is cleared and the reference warms up again.
    """

    def __init__(self, frames: int = 25, min_frames: int = 5) -> None:
        if frames < 1 or not 1 <= min_frames <= frames:
            raise ValueError(f"need 1 <= min_frames <= frames, got {min_frames}, {frames}")
        self.frames = frames
        self.min_frames = min_frames
        self._recent: deque[float] = deque()
        self._sorted: list[float] = []
        self._rejected_run = 0

    @property
    def value(self) -> float | None:
        s = self._sorted
        n = len(s)
        if n < self.min_frames:
            return None
        return s[n // 2] if n % 2 else (s[n // 2 - 1] + s[n // 2]) / 2.0

    def update(self, bg_std: float, *, accepted: bool, rejected: bool) -> None:
        """Offer one frame's background std: kept if ``accepted``; ``rejected`` (contaminated)
        counts toward the reset; anything else (undefined, saturated, ...) is ignored."""
        if rejected:
            self._rejected_run += 1
            if self._rejected_run >= self.frames:
                self.clear()
            return
        if not accepted:
            return
        self._rejected_run = 0
        self._recent.append(bg_std)
        bisect.insort(self._sorted, bg_std)
        if len(self._recent) > self.frames:
            old = self._recent.popleft()
            del self._sorted[bisect.bisect_left(self._sorted, old)]

    def clear(self) -> None:
        self._recent.clear()
        self._sorted.clear()
        self._rejected_run = 0

    def snapshot(self) -> dict:
        """The history, exactly (JSON-able), for :meth:`restore`."""
        return {"recent": list(self._recent), "rejected_run": self._rejected_run}

    def restore(self, state: dict) -> None:
        self._recent = deque(float(v) for v in state["recent"])
        self._sorted = sorted(self._recent)
        self._rejected_run = int(state["rejected_run"])
