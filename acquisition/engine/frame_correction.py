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
from snrmon.acquisition.engine.background_reference import BackgroundReference
from snrmon.acquisition.engine.lazy_frame import LazyFrame, PixelMaker, Region
from snrmon.acquisition.stage_clock import CORRECTION, enter

TILE_PX = 8  # a read corrects the 8 px tiles it falls in (within the square)
AROUND_PX = 10  # corrected around the centre before the first read (FrameCorrector.apply)
_NONE = np.zeros((1, 1), np.float32)  # an absent map, for the compiled correction


def _float32_maps(cal, shape: tuple[int, int]) -> bool:
    """The calibration's maps are float32 of the frame's shape (what the compiled correction
    computes with; any other is NumPy's to promote)."""
    return (
        cal.shape == shape
        and cal.offset_dn.dtype == np.float32
        and cal.safe_responsivity.dtype == np.float32
    )


class CompiledMaps:
    """The maps :func:`snrmon.acquisition.calibrate.kernels.lazy_correct` corrects with into
    ``buffer``, or None where NumPy must (maps of another type or shape: NumPy's promotions);
    the same tuple for as long as the calibration, the reference and the frames' shape are."""

    def __init__(self, shape: tuple[int, int], buffer: np.ndarray) -> None:
        self.shape = shape
        self.buffer = buffer
        self._cached: tuple | None = None  # (calibration, reference, shape, their maps)

    def of(self, pixels: np.ndarray, cal, ref: np.ndarray | None) -> tuple | None:
        cached = self._cached
        if (
            cached is not None
            and cached[0] is cal
            and cached[1] is ref
            and cached[2] == pixels.shape
        ):
            return cached[3]
        fast = self._maps(pixels, cal, ref)
        self._cached = (cal, ref, pixels.shape, fast)
        return fast

    def _maps(self, pixels: np.ndarray, cal, ref: np.ndarray | None) -> tuple | None:
        if pixels.shape != self.shape or not (cal is None or _float32_maps(cal, self.shape)):
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
                self.buffer,
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
            self.buffer,
        )


class CorrectedRegions:
    """What this frame has corrected so far, within the square :meth:`FrameCorrector.apply`
    corrects: the boxes as Python tuples, and the same for the compiled path as arrays
    (``state``: square y0, y1, x0, x1, tile, boxes; ``boxes``)."""

    def __init__(self) -> None:
        self.square: Region = (0, 0, 0, 0)
        self.done: list[Region] = []  # regions corrected this frame
        self.covered: list[Region] = []  # ... by the compiled path, as Python tuples
        self.state = np.zeros(6, np.int64)
        self.boxes = np.zeros((64, 4), np.int64)

    def new_frame(self, square: Region) -> None:
        """A new frame of ``square``: nothing corrected yet."""
        self.square = square
        self.done = []
        self.covered = []
        self.state[:] = (*square, TILE_PX, 0)

    def add_done(self, box: Region) -> None:
        """``box`` is corrected this frame (for both paths of :meth:`FrameCorrector.ensure`)."""
        self.done.append(box)
        n = int(self.state[5])
        if n < len(self.boxes):
            self.boxes[n] = box
            self.state[5] = n + 1

    def last_compiled_box(self) -> Region:
        """The box the compiled path added last (as a Python tuple)."""
        return tuple(self.boxes[int(self.state[5]) - 1].tolist())


class FrameCorrector:
    """Applies the background reference and/or a calibration inside a window around the ROI."""

    def __init__(self, shape: tuple[int, int], half_px: int, *, lazy: bool = True) -> None:
        self.shape = (int(shape[0]), int(shape[1]))
        self.half_px = int(half_px)
        self.lazy = lazy
        self._calibration = None
        self.reference = BackgroundReference(self.shape)
        self._buffer = np.zeros(self.shape, np.float32)
        self._lazy_frame = LazyFrame.of(self._buffer, self)
        self._maps = CompiledMaps(self.shape, self._buffer)
        self._pixels: np.ndarray | None = None  # the frame being read (lazy)
        self._raw: PixelMaker | None = None  # its owner, when the raw frame is read lazily too
        self._fast: tuple | None = None  # this frame's compiled maps (None: NumPy's path)
        self.regions = CorrectedRegions()

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
    def reference_offset(self) -> np.ndarray | None:
        """The background reference's offset image subtracted (None: no reference)."""
        return self.reference.offset

    @property
    def reference_frames(self) -> int:
        return self.reference.frames

    @property
    def fixed_pattern_dn(self) -> float:
        """The spatial std of the reference offsets (NaN: no reference)."""
        return self.reference.fixed_pattern_dn

    @property
    def reference_summary(self) -> dict | None:
        """The summary of the reference in force."""
        return self.reference.summary

    @property
    def active(self) -> bool:
        return self.calibration is not None or self.reference.offset is not None

    @property
    def capturing(self) -> bool:
        return self.reference.capturing

    def start_reference(self, n_frames: int) -> None:
        """Average the next ``n_frames`` frames into a new background reference."""
        self.reference.start(n_frames)

    def clear_reference(self) -> None:
        self.reference.clear()

    def feed(self, pixels: np.ndarray, counter: int) -> dict | None:
        """Offer a frame to a capture in progress; returns the capture's summary when it ends
        (first/last counter, frames, the reference's spatial std = fixed-pattern noise, DN)."""
        return self.reference.feed(pixels, counter, self.calibration)

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
        self.reference.set_offset(offset, summary)

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
        square = (y0, y1, x0, x1)
        # A raw frame read as it is read (replay --fast's row strips): its rows are made before
        # each correction reads them (_correct, ensure), the kernels get the plain buffer.
        self._raw = pixels.owner if type(pixels) is LazyFrame else None
        pixels = pixels.view(np.ndarray) if self._raw is not None else pixels
        if not self.lazy:
            self.regions.square = square
            self._correct(pixels, square, bad=self._has_bad(square))
            return self._buffer
        self._pixels = pixels
        self.regions.new_frame(square)
        self._fast = self._compiled(pixels)
        # The reads of a tracked unresolved drone (the brightest pixel near the prediction, the
        # object's analysis window, Eq. 4's rims) lie within AROUND_PX of the centre: one
        # correction now instead of two or three as they come (the same pixels either way).
        a = AROUND_PX
        self.ensure((y - a, y + a + 1, x - a, x + a + 1))
        return self._lazy_frame

    def _compiled(self, pixels: np.ndarray) -> tuple | None:
        """The maps the compiled correction uses for ``pixels`` (:class:`CompiledMaps`)."""
        return self._maps.of(pixels, self.calibration, self.reference.offset)

    def ensure(self, region: Region | None) -> None:
        """Correct ``region`` of the frame given to :meth:`apply` (within its square; None: the
        whole square) unless this frame has corrected it already (:class:`LazyFrame`)."""
        fast, pixels = self._fast, self._pixels
        if fast is not None and region is not None and pixels is not None:
            y0, y1, x0, x1 = region
            regions = self.regions
            for b in regions.covered:  # most reads fall in a box an earlier read corrected
                if b[0] <= y0 and y1 <= b[1] and b[2] <= x0 and x1 <= b[3]:
                    return
            running = enter(CORRECTION)  # a read of the tracker or Eq. (4) corrects first
            if self._raw is not None:  # the rows of the tiles lazy_correct reads (its rounding)
                sy0, sy1 = regions.square[0], regions.square[1]
                t = TILE_PX
                self._raw.ensure((max(y0 // t * t, sy0), min(-(-y1 // t) * t, sy1), x0, x1))
            done = lazy_correct(pixels, y0, y1, x0, x1, regions.state, regions.boxes, *fast)
            if done == 2:
                regions.covered.append(regions.last_compiled_box())
            elif done == 1:
                # A bad pixel: its replacement depends on the whole square (NumPy).
                self._correct(pixels, regions.square)
                regions.add_done(regions.square)
                regions.covered.append(regions.square)
            enter(running)
            return
        running = enter(CORRECTION)
        try:
            self._ensure(region)
        finally:
            enter(running)

    def _ensure(self, region: Region | None) -> None:
        regions = self.regions
        sy0, sy1, sx0, sx1 = regions.square
        if region is None:
            y0, y1, x0, x1 = sy0, sy1, sx0, sx1
        else:
            y0, y1 = max(region[0], sy0), min(region[1], sy1)
            x0, x1 = max(region[2], sx0), min(region[3], sx1)
            if y0 >= y1 or x0 >= x1:
                return  # outside the square: never read (reach_px), left as it stands
        for d in regions.done:
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
            box = regions.square
        self._correct(self._pixels, box, bad=bad)
        regions.add_done(box)

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
        ref = self.reference.offset
        if ref is not None:
            win = win - ref[y0:y1, x0:x1]
        self._buffer[y0:y1, x0:x1] = win
