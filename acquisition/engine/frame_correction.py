"""What is done to a raw frame before Eq. (4): fixed-pattern removal and calibration.

- Background reference (paper sections 3 and 6: "the fixed pattern noise is removed from the
  scenes through temporal averaging"): the temporal mean of N frames of clear sky (taken before
  launch, or with the drone out of the field), minus its own spatial mean, is each pixel's
  fixed-pattern offset; subtracting it leaves the temporal noise. Frames with the drone in view
  would put the drone into the reference, so the operator captures it on empty sky.
- Radiometric calibration (:class:`snrmon.acquisition.calibrate.calibration.Calibration`): per-pixel
two-point
  non-uniformity correction; the reference, if any, is then taken on corrected frames.

Both are applied only inside the square around the track that the measurement may read
(:func:`snrmon.acquisition.engine.frame_measurer.crop_half_px`-sized), written into a float32
full-frame buffer, so the cost does not grow with the frame. Within that square only what the
measurement reads is corrected, as it reads it
(:class:`snrmon.acquisition.engine.lazy_frame.LazyFrame`, in
``TILE_PX`` tiles): each pixel's correction is its own (per-pixel gain, offset and reference), so
a pixel corrected alone equals the same pixel of the whole square, bit for bit. Two cases are
corrected whole, as before: a region holding a bad pixel of the calibration (its replacement is
a median over the square's neighbours and the square's own median), and a measurement that reads
a fixed clear-sky rectangle (it may lie outside the square: the buffer is read as it stands,
``lazy=False``). The recording always keeps the raw frames.
"""

from __future__ import annotations

import numpy as np

from snrmon.acquisition.calibrate.kernels import any_set, correct_box, lazy_correct
from snrmon.acquisition.engine.lazy_frame import LazyFrame, PixelMaker, Region, plain
from snrmon.acquisition.stage_clock import CORRECTION, enter

TILE_PX = 8  # a read corrects the 8 px tiles it falls in (within the square)
AROUND_PX = 10  # corrected around the centre before the first read (FrameCorrector.apply)
_NONE = np.zeros((1, 1), np.float32)  # an absent map, for the compiled correction


def _float32_maps(cal, corrector: FrameCorrector) -> bool:
    """The calibration's maps are float32 of the frame's shape (what the compiled correction
    computes with; any other is NumPy's to promote)."""
    return (
        cal.shape == corrector.shape
        and cal.offset_dn.dtype == np.float32
        and cal.safe_responsivity.dtype == np.float32
    )


class FrameCorrector:
    """Applies the background reference and/or a calibration inside a window around the ROI."""

    def __init__(self, shape: tuple[int, int], half_px: int, *, lazy: bool = True) -> None:
        self.shape = (int(shape[0]), int(shape[1]))
        self.half_px = int(half_px)
        self.lazy = lazy
        self.calibration = None
        self.reference_offset: np.ndarray | None = None
        self.reference_frames = 0
        self.fixed_pattern_dn = float("nan")  # spatial std of the reference offsets
        self.reference_summary: dict | None = None  # the summary of the reference in force
        self._buffer = np.zeros(self.shape, np.float32)
        self._lazy_frame = LazyFrame.of(self._buffer, self)
        self._pixels: np.ndarray | None = None  # the frame being read (lazy)
        self._raw: PixelMaker | None = None  # its owner, when the raw frame is read lazily too
        self._square: Region = (0, 0, 0, 0)  # what apply() corrects this frame
        self._done: list[Region] = []  # regions corrected this frame
        self._covered: list[Region] = []  # ... by the compiled path, as Python tuples
        # The same for the compiled path: (square y0, y1, x0, x1, tile, boxes), the boxes.
        self._state = np.zeros(6, np.int64)
        self._boxes = np.zeros((64, 4), np.int64)
        self._fast: tuple | None = None
        self._fast_for: tuple | None = None  # (calibration, reference, shape, their maps)
        self._sum: np.ndarray | None = None
        self._wanted = 0
        self._counters: list[int] = []

    @property
    def calibration(self):
        """The radiometric calibration applied (None: none)."""
        return self._calibration

    @calibration.setter
    def calibration(self, calibration) -> None:
        self._calibration = calibration
        if calibration is not None:
            # The maps and means the correction uses (cached on the calibration): computed
            # now, not in the first frame's time (about 8 ms for a 1280 x 720 camera).
            _ = calibration.safe_responsivity, calibration.mean_offset_dn

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
        pixels = plain(pixels)  # a reference is of every pixel
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
        nothing is active or no ROI is set. Lazy (the default), the window's pixels are
        corrected as they are read, until the next call."""
        if not self.active or roi is None:
            return pixels
        x, y = roi
        h = self.half_px
        y0, y1 = max(y - h, 0), min(y + h + 1, self.shape[0])
        x0, x1 = max(x - h, 0), min(x + h + 1, self.shape[1])
        self._square = (y0, y1, x0, x1)
        # A raw frame read as it is read (replay --fast's row strips): its rows are made before
        # each correction reads them (_correct, ensure), the kernels get the plain buffer.
        self._raw = pixels.owner if type(pixels) is LazyFrame else None
        pixels = pixels.view(np.ndarray) if self._raw is not None else pixels
        if not self.lazy:
            self._correct(pixels, self._square, bad=self._has_bad(self._square))
            return self._buffer
        self._pixels = pixels
        self._done = []
        self._covered = []
        self._state[:] = (y0, y1, x0, x1, TILE_PX, 0)
        self._fast = self._compiled(pixels)
        # The reads of a tracked unresolved drone (the brightest pixel near the prediction, the
        # object's analysis window, Eq. 4's rims) lie within AROUND_PX of the centre: one
        # correction now instead of two or three as they come (the same pixels either way).
        a = AROUND_PX
        self.ensure((y - a, y + a + 1, x - a, x + a + 1))
        return self._lazy_frame

    def _compiled(self, pixels: np.ndarray) -> tuple | None:
        """The maps :func:`snrmon.acquisition.calibrate.kernels.lazy_correct` corrects with, or None
        where NumPy must (maps of another type or shape: NumPy's promotions); the same tuple
        for as long as the calibration, the reference and the frames' shape are."""
        cal, ref = self.calibration, self.reference_offset
        cached = self._fast_for
        if (
            cached is not None
            and cached[0] is cal
            and cached[1] is ref
            and cached[2] == pixels.shape
        ):
            return cached[3]
        fast = self._maps(pixels, cal, ref)
        self._fast_for = (cal, ref, pixels.shape, fast)
        return fast

    def _maps(self, pixels: np.ndarray, cal, ref) -> tuple | None:
        if pixels.shape != self.shape or not (cal is None or _float32_maps(cal, self)):
            return None
        if cal is None:
            return (
                _NONE,
                _NONE,
                _NONE if ref is None else ref,
                _NONE,
                0.0,
                0.0,
                False,
                ref is not None,
                self._buffer,
            )
        return (
            cal.offset_dn,
            cal.safe_responsivity,
            _NONE if ref is None else ref,
            cal.bad,
            cal.mean_offset_dn,
            cal.mean_responsivity,
            True,
            ref is not None,
            self._buffer,
        )

    def ensure(self, region: Region | None) -> None:
        """Correct ``region`` of the frame given to :meth:`apply` (within its square; None: the
        whole square) unless this frame has corrected it already (:class:`LazyFrame`)."""
        fast, pixels = self._fast, self._pixels
        if fast is not None and region is not None and pixels is not None:
            y0, y1, x0, x1 = region
            for b in self._covered:  # most reads fall in a box an earlier read corrected
                if b[0] <= y0 and y1 <= b[1] and b[2] <= x0 and x1 <= b[3]:
                    return
            running = enter(CORRECTION)  # a read of the tracker or Eq. (4) corrects first
            if self._raw is not None:  # the rows of the tiles lazy_correct reads (its rounding)
                sy0, sy1 = self._square[0], self._square[1]
                t = TILE_PX
                self._raw.ensure((max(y0 // t * t, sy0), min(-(-y1 // t) * t, sy1), x0, x1))
            done = lazy_correct(pixels, y0, y1, x0, x1, self._state, self._boxes, *fast)
            if done == 2:
                self._covered.append(tuple(self._boxes[int(self._state[5]) - 1].tolist()))
            elif done == 1:
                # A bad pixel: its replacement depends on the whole square (NumPy).
                self._correct(pixels, self._square)
                self._done_box(self._square)
                self._covered.append(self._square)
            enter(running)
            return
        running = enter(CORRECTION)
        try:
            self._ensure(region)
        finally:
            enter(running)

    def _ensure(self, region: Region | None) -> None:
        sy0, sy1, sx0, sx1 = self._square
        if region is None:
            y0, y1, x0, x1 = sy0, sy1, sx0, sx1
        else:
            y0, y1 = max(region[0], sy0), min(region[1], sy1)
            x0, x1 = max(region[2], sx0), min(region[3], sx1)
            if y0 >= y1 or x0 >= x1:
                return  # outside the square: never read (reach_px), left as it stands
        for d in self._done:
            if d[0] <= y0 and y1 <= d[1] and d[2] <= x0 and x1 <= d[3]:
                return
        if self._pixels is None:
            return  # not a lazy frame (or already dropped): the buffer is what it is
        t = TILE_PX
        y0, y1 = max(y0 // t * t, sy0), min(-(-y1 // t) * t, sy1)
        x0, x1 = max(x0 // t * t, sx0), min(-(-x1 // t) * t, sx1)
        box = (y0, y1, x0, x1)
        bad = self._has_bad(box)
        if bad:  # its replacement depends on the whole square: correct it all
            box = self._square
        self._correct(self._pixels, box, bad=bad)
        self._done_box(box)

    def _done_box(self, box: Region) -> None:
        """``box`` is corrected this frame (for both paths of :meth:`ensure`)."""
        self._done.append(box)
        n = int(self._state[5])
        if n < len(self._boxes):
            self._boxes[n] = box
            self._state[5] = n + 1

    def _has_bad(self, box: Region) -> bool:
        """True when the calibration marks a bad pixel in ``box`` (looked at directly: a box
        is a few hundred pixels)."""
        cal = self.calibration
        if cal is None:
            return False
        y0, y1, x0, x1 = box
        return any_set(cal.bad, y0, y1, x0, x1)

    def _correct(self, pixels: np.ndarray, box: Region, *, bad: bool = True) -> None:
        """The correction of ``box`` into the buffer. The calibration's bad-pixel replacement
        depends on the box (a median over it); every other pixel's value does not. A box
        without bad pixels (``bad`` False: :meth:`_has_bad` said so) is corrected by compiled
        code, bit for bit the same (:func:`snrmon.acquisition.calibrate.kernels.correct_box`)."""
        y0, y1, x0, x1 = box
        if self._raw is not None:
            self._raw.ensure(box)
        fast = None if bad else self._compiled(pixels)  # the maps lazy_correct uses
        if fast is not None:
            offset, resp, ref, _, mo, mr, calibrate, subtract, out = fast
            correct_box(pixels, y0, y1, x0, x1, offset, resp, mo, mr, ref, calibrate, subtract, out)
            return
        if self.calibration is not None:
            win = self.calibration.correct(pixels, (y0, y1, x0, x1))
        else:
            win = pixels[y0:y1, x0:x1].astype(np.float32)
        if self.reference_offset is not None:
            win = win - self.reference_offset[y0:y1, x0:x1]
        self._buffer[y0:y1, x0:x1] = win
