"""The background reference (paper sections 3 and 6: "the fixed pattern noise is removed from the
scenes through temporal averaging"): the temporal mean of N frames of clear sky, minus its own
spatial mean, is each pixel's fixed-pattern offset. :class:`BackgroundReference` holds the one in
force and accumulates a capture in progress; the corrector
(:class:`snrmon.acquisition.engine.frame_correction.FrameCorrector`) subtracts it.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from snrmon.acquisition.engine.lazy_frame import plain


class BackgroundReference:
    """One camera's fixed-pattern offset image in force (None: none) with its summary, and the
    capture in progress that will replace it."""

    def __init__(self, shape: tuple[int, int]) -> None:
        self.shape = shape
        self.offset: np.ndarray | None = None  # float32: subtracted from each corrected pixel
        # first/last counter, frames, the offset's spatial std (fixed-pattern noise, DN)
        self.summary: dict[str, Any] | None = None
        self._sum: np.ndarray | None = None  # the capture's running sum (None: no capture)
        self._wanted = 0
        self._counters: list[int] = []

    @property
    def frames(self) -> int:
        """Frames averaged into the reference in force (0: none)."""
        return int(self.summary["n_frames"]) if self.summary is not None else 0

    @property
    def fixed_pattern_dn(self) -> float:
        """The spatial std of the reference's offsets (NaN: none)."""
        return float(self.summary["spatial_std_dn"]) if self.summary is not None else math.nan

    @property
    def capturing(self) -> bool:
        return self._sum is not None

    def start(self, n_frames: int) -> None:
        """Average the next ``n_frames`` frames into a new reference."""
        if int(n_frames) < 2:
            raise ValueError(f"a background reference needs at least 2 frames, got {n_frames}")
        self._sum = np.zeros(self.shape, np.float64)
        self._wanted = int(n_frames)
        self._counters = []

    def clear(self) -> None:
        """No reference in force and no capture."""
        self.offset = None
        self.summary = None
        self._sum = None

    def feed(self, pixels: np.ndarray, counter: int, calibration) -> dict | None:
        """Offer a frame to a capture in progress (corrected by ``calibration`` first, if any);
        returns the capture's summary when it ends."""
        if self._sum is None:
            return None
        pixels = plain(pixels)  # a reference is of every pixel
        frame = calibration.correct(pixels) if calibration is not None else pixels
        self._sum += frame
        self._counters.append(int(counter))
        if len(self._counters) < self._wanted:
            return None
        mean = self._sum / len(self._counters)
        self.offset = (mean - mean.mean()).astype(np.float32)
        self._sum = None
        self.summary = {
            "n_frames": len(self._counters),
            "first_counter": self._counters[0],
            "last_counter": self._counters[-1],
            "spatial_std_dn": float(self.offset.std()),
        }
        return dict(self.summary)

    def set_offset(self, offset: np.ndarray, summary: dict) -> None:
        """A reference captured before (its offset image and summary), in force as it was."""
        offset = np.asarray(offset, np.float32)
        if offset.shape != self.shape:
            raise ValueError(f"reference of shape {offset.shape}, frames are {self.shape}")
        self.offset = offset
        self.summary = dict(summary)
        self._sum = None
