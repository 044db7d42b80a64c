"""Running mean and sample std of the per-frame peak SNR over the last N values (paper section 5).

The paper averages 100 per-frame SNR values (never the frames): "The average and the standard
deviation of the 100 peak SNR values constituted the peak SNR."

Policy for values that are not numbers: a NaN or infinite SNR never enters the window (it is
skipped, so the window always holds the last N *finite* values pushed). Which flagged frames are
pushed at all is the caller's decision (see
:class:`snrmon.acquisition.measure.peak_snr.PeakSnrMeter`).

Cost: O(1) per push (Welford update with removal of the value leaving the window); to stop
rounding drift accumulating over a long session, the sums are recomputed exactly from the window
every N pushes (O(N) once per N pushes, so still O(1) amortised).
"""

from __future__ import annotations

import math

import numpy as np


class RunningSnr:
    """Mean and sample (N-1) standard deviation of the last ``window`` finite SNR values."""

    def __init__(self, window: int = 100) -> None:
        if int(window) != window or window < 1:
            raise ValueError(f"running window must be a positive integer, got {window}")
        self.window = int(window)
        self._buf = np.zeros(self.window, dtype=np.float64)
        self._next = 0  # where the next value goes in the ring
        self._count = 0
        self._mean = 0.0
        self._m2 = 0.0  # sum of squared deviations from the mean
        self._since_exact = 0

    def push(self, snr: float) -> bool:
        """Add one per-frame SNR; returns False (and ignores it) when it is not finite."""
        x = float(snr)
        if not math.isfinite(x):
            return False
        if self._count == self.window:
            old = float(self._buf[self._next])
            self._buf[self._next] = x
            # Replace old by x in one step (count unchanged): exact algebra of the two updates.
            d_old = old - self._mean
            self._mean += (x - old) / self._count
            self._m2 += (x - old) * (x - self._mean + d_old)
        else:
            self._buf[self._next] = x
            self._count += 1
            d = x - self._mean
            self._mean += d / self._count
            self._m2 += d * (x - self._mean)
        self._next = (self._next + 1) % self.window
        self._since_exact += 1
        if self._since_exact >= self.window:
            self._recompute()
        elif self._m2 < 0.0:
            self._m2 = 0.0
        return True

    def _recompute(self) -> None:
        values = self._buf[: self._count] if self._count < self.window else self._buf
        self._mean = float(values.mean()) if self._count else 0.0
        self._m2 = float(((values - self._mean) ** 2).sum()) if self._count else 0.0
        self._since_exact = 0

    def clear(self) -> None:
        """Forget every value (a new stop, a new ROI)."""
        self._next = 0
        self._count = 0
        self._mean = 0.0
        self._m2 = 0.0
        self._since_exact = 0

    @property
    def count(self) -> int:
        """How many values the window holds now (<= window)."""
        return self._count

    @property
    def full(self) -> bool:
        """True once the window holds ``window`` values."""
        return self._count == self.window

    @property
    def mean(self) -> float:
        """Mean of the values in the window; NaN when it is empty."""
        return self._mean if self._count else math.nan

    @property
    def std(self) -> float:
        """Sample standard deviation (ddof=1, MATLAB ``std``); NaN with fewer than 2 values."""
        if self._count < 2:
            return math.nan
        return math.sqrt(max(self._m2, 0.0) / (self._count - 1))

    def snapshot(self) -> dict:
        """Everything the window holds, exactly (JSON-able; floats round-trip through ``repr``),
        so a restored window continues bit-identically (the replay across a recording gap)."""
        return {
            "buf": self._buf.tolist(),
            "next": self._next,
            "count": self._count,
            "mean": self._mean,
            "m2": self._m2,
            "since_exact": self._since_exact,
        }

    def restore(self, state: dict) -> None:
        """Restore what :meth:`snapshot` returned (same ``window``)."""
        buf = np.asarray(state["buf"], dtype=np.float64)
        if buf.shape != self._buf.shape:
            raise ValueError(f"running window of {buf.size} values, this one holds {self.window}")
        self._buf[:] = buf
        self._next = int(state["next"])
        self._count = int(state["count"])
        self._mean = float(state["mean"])
        self._m2 = float(state["m2"])
        self._since_exact = int(state["since_exact"])

    def values(self) -> np.ndarray:
        """The window's values, oldest first (a copy)."""
        if self._count < self.window:
            return self._buf[: self._count].copy()
        # np.roll's own bookkeeping costs 5 us; the two slices joined, under 1 us (per frame)
        return np.concatenate((self._buf[self._next :], self._buf[: self._next]))
