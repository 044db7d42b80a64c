"""What is done to a raw frame before Eq. (4): fixed-pattern removal and calibration.

- Background reference (paper sections 3 and 6: "the fixed pattern noise is removed from the
  scenes through temporal averaging"): the temporal mean of N frames of clear sky (taken before
  launch, or with the drone out of the field), minus its own spatial mean, is each pixel's
  fixed-pattern offset; subtracting it leaves the temporal noise. Frames with the drone in view
  would put the drone into the reference, so the operator captures it on empty sky.
- Radiometric calibration (:class:`acquisition.calibrate.calibration.Calibration`): per-pixel
two-point
  non-uniformity correction; the reference, if any, is then taken on corrected frames.

Both are applied only to the square around the track that the measurement reads
(:func:`acquisition.replay.batch.crop_half_px`-sized), written into a float32 full-frame buffer, so
the cost does not grow with the frame. The recording always keeps the raw frames.
"""

from __future__ import annotations

import numpy as np


class FrameCorrector:
    """Applies the background reference and/or a calibration inside a window around the ROI."""

    def __init__(self, shape: tuple[int, int], half_px: int) -> None:
        self.shape = (int(shape[0]), int(shape[1]))
        self.half_px = int(half_px)
        self.calibration = None
        self.reference_offset: np.ndarray | None = None
        self.reference_frames = 0
        self.fixed_pattern_dn = float("nan")  # spatial std of the reference offsets
        self.reference_summary: dict | None = None  # the summary of the reference in force
        self._buffer = np.zeros(self.shape, np.float32)
        self._sum: np.ndarray | None = None
        self._wanted = 0
        self._counters: list[int] = []

    @property
    def active(self) -> bool:
        return self.calibration is not None or self.reference_offset is not None

    @property
    def capturing(self) -> bool:
        return self._sum is not None

    def start_reference(self, n_frames: int) -> None:
        """Average the next ``n_frames`` frames into a new background reference."""
        if int(n_frames) < 2:
            raise ValueError(f"a background reference needs at least 2 frames, got {n_frames}")
        self._sum = np.zeros(self.shape, np.float64)
        self._wanted = int(n_frames)
        self._counters = []

    def clear_reference(self) -> None:
        self.reference_offset = None
        self.reference_frames = 0
        self.fixed_pattern_dn = float("nan")
        self.reference_summary = None
        self._sum = None

    def feed(self, pixels: np.ndarray, counter: int) -> dict | None:
        """Offer a frame to a capture in progress; returns the capture's summary when it ends
        (first/last counter, frames, the reference's spatial std = fixed-pattern noise, DN)."""
        if self._sum is None:
            return None
        frame = self.calibration.correct(pixels) if self.calibration is not None else pixels
        self._sum += frame
        self._counters.append(int(counter))
        if len(self._counters) < self._wanted:
            return None
        mean = self._sum / len(self._counters)
        self.reference_offset = (mean - mean.mean()).astype(np.float32)
        self.reference_frames = len(self._counters)
        self.fixed_pattern_dn = float(self.reference_offset.std())
        self._sum = None
        self.reference_summary = {
            "n_frames": self.reference_frames,
            "first_counter": self._counters[0],
            "last_counter": self._counters[-1],
            "spatial_std_dn": self.fixed_pattern_dn,
        }
        return dict(self.reference_summary)

    def set_reference(self, frames: np.ndarray, counters) -> dict:
        """A reference from recorded frames (replay of a format 1 ``background_reference``
        event), through the very same accumulation as a live capture, so it is bit-identical;
        returns its summary."""
        self.start_reference(len(frames))
        summary = None
        for frame, counter in zip(frames, counters, strict=True):
            summary = self.feed(frame, int(counter))
        assert summary is not None
        return summary

    def set_reference_offset(self, offset: np.ndarray, summary: dict) -> None:
        """A reference captured before (the recorded offset image and its summary): applied
        exactly as it was live, whatever frames the recording kept."""
        offset = np.asarray(offset, np.float32)
        if offset.shape != self.shape:
            raise ValueError(f"reference of shape {offset.shape}, frames are {self.shape}")
        self.reference_offset = offset
        self.reference_frames = int(summary["n_frames"])
        self.fixed_pattern_dn = float(summary["spatial_std_dn"])
        self.reference_summary = dict(summary)
        self._sum = None

    def apply(self, pixels: np.ndarray, roi: tuple[int, int] | None) -> np.ndarray:
        """The corrected frame in the window around ``roi`` (float32); the raw frame when
        nothing is active or no ROI is set."""
        if not self.active or roi is None:
            return pixels
        x, y = roi
        h = self.half_px
        y0, y1 = max(y - h, 0), min(y + h + 1, self.shape[0])
        x0, x1 = max(x - h, 0), min(x + h + 1, self.shape[1])
        if self.calibration is not None:
            win = self.calibration.correct(pixels, (y0, y1, x0, x1))
        else:
            win = pixels[y0:y1, x0:x1].astype(np.float32)
        if self.reference_offset is not None:
            win = win - self.reference_offset[y0:y1, x0:x1]
        self._buffer[y0:y1, x0:x1] = win
        return self._buffer
