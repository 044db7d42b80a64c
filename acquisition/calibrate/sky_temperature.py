"""Live apparent sky (background) temperature per camera, as a time series.

The background region is the one Eq. 4 uses (paper section 5): the 24 rim pixels of the 7x7 box
around the frame's peak (from its :class:`snrmon.acquisition.measure.peak_snr.PeakSnr`), or the
operator's clear-sky rectangle. For a frame measured against the ``extent_rim`` background (a drone
wider than the box's guard) the 7x7 rim lies on the drone itself and would read it, not
the sky: the rim of the square around the peak that holds the segmented extent and its 2 px guard
(half-size max(extent width, height) + 2) is used instead, the sky outside the drone.

Per frame the region's raw DN are turned into in-band radiance through the
camera's calibration, averaged IN RADIANCE (the physical mean of the flux the pixels see; the
model's background input is a radiance), and reported as the brightness temperature of that
mean. Only the region's pixels are read, so the cost does not depend on the frame size. This is
the measured background of the paper's path-radiance correction (sections 8-9).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np

from snrmon.acquisition.calibrate.calibration import Calibration, temperature_of, temperature_table
from snrmon.acquisition.calibrate.kernels import sky_sample
from snrmon.acquisition.measure.background import Rect, rim_offsets, validate_rect
from snrmon.acquisition.measure.peak_snr import BACKGROUND_EXTENT, PeakSnr


@dataclass(frozen=True, slots=True)
class SkySample:
    """One frame's background: time on the common clock, mean in-band radiance of the good
    pixels of the region, its brightness temperature [K], the spread of the pixels' apparent
    temperatures [K] and how many pixels were used."""

    t_host_ns: int
    radiance: float
    temp_k: float
    temp_std_k: float
    n_pixels: int


class SkyTemperature:
    """Fed one frame at a time (``add``); keeps the last ``maxlen`` samples.

    ``rect`` (inclusive ``(x0, y0, x1, y1)``) fixes the region; without it the rim of
    ``box_px`` around each frame's peak is used and the frame's PeakSnr is required."""

    def __init__(
        self,
        camera: str,
        calibration: Calibration,
        *,
        rect: Rect | None = None,
        box_px: int = 7,
        maxlen: int = 36000,
    ) -> None:
        if calibration.camera != camera:
            raise ValueError(f"calibration is for camera {calibration.camera!r}, not {camera!r}")
        self.camera = camera
        self.calibration = calibration
        self.rect = validate_rect(rect, calibration.shape) if rect is not None else None
        self.box_px = int(box_px)
        self._rim = rim_offsets(self.box_px)
        if self.rect is not None:
            x0, y0, x1, y1 = self.rect
            rows, cols = np.mgrid[y0 : y1 + 1, x0 : x1 + 1]
            self._rect_pixels = (rows.ravel().astype(np.intp), cols.ravel().astype(np.intp))
        self._samples: deque[SkySample] = deque(maxlen=int(maxlen))
        t, radiance = temperature_table(
            tuple(map(float, calibration.band_um)), tuple(calibration.qe_curve)
        )
        self._table = (radiance, t)  # radiance -> temperature (temperature_of's table)

    def _region(self, result: PeakSnr | None) -> tuple[np.ndarray, np.ndarray, int, int]:
        """(dy, dx, y, x): the region's pixels are (y + dy, x + dx)."""
        if self.rect is not None:
            return (*self._rect_pixels, 0, 0)
        if result is None:
            raise ValueError("the rim background needs the frame's PeakSnr (or set a rect)")
        dy, dx = self._rim
        if result.background == BACKGROUND_EXTENT and max(result.extent_w_px, result.extent_h_px):
            # Any extent pixel lies within max(w, h) - 1 of the peak; the guard adds 2 more.
            half = max(self.box_px // 2, max(result.extent_w_px, result.extent_h_px) + 2)
            dy, dx = rim_offsets(2 * half + 1)
        return dy, dx, result.peak_y, result.peak_x

    def box(self, result: PeakSnr | None = None) -> tuple[int, int, int, int]:
        """Rows y0:y1 and columns x0:x1 (half-open) that hold the pixels :meth:`add` reads of a
        frame measured as ``result``."""
        dy, dx, y, x = self._region(result)
        return y + int(dy.min()), y + int(dy.max()) + 1, x + int(dx.min()), x + int(dx.max()) + 1

    def add(self, t_host_ns: int, frame: np.ndarray, result: PeakSnr | None = None):
        """The frame's :class:`SkySample` (also kept), or None when the region is unusable
        (it leaves the image: the measurement flags that too; fewer than two good pixels).
        One compiled call (:func:`snrmon.acquisition.calibrate.kernels.sky_sample`): the radiances,
        their mean, the table lookups (numba's np.interp, NumPy's algorithm) and the spread."""
        dy, dx, y, x = self._region(result)
        cal = self.calibration
        maps = (cal.offset_dn, cal.responsivity, cal.bad)
        n, mean_lq, temp, spread = sky_sample(frame, *maps, dy, dx, y, x, *self._table)
        if n < 2:
            return None
        sample = SkySample(int(t_host_ns), mean_lq, temp, spread, n)
        self._samples.append(sample)
        return sample

    def __len__(self) -> int:
        return len(self._samples)

    def samples(self) -> list[SkySample]:
        return list(self._samples)

    def series(self) -> tuple[np.ndarray, np.ndarray]:
        """(t_host_ns int64, temp_k float64) arrays of the kept samples, oldest first."""
        t = np.fromiter((s.t_host_ns for s in self._samples), np.int64, len(self._samples))
        k = np.fromiter((s.temp_k for s in self._samples), np.float64, len(self._samples))
        return t, k

    def mean_temp_k(self, last: int | None = None) -> float:
        """Brightness temperature of the mean radiance of the last ``last`` samples (all by
        default); NaN without samples. This is what the model's background input follows."""
        s = list(self._samples)[-last:] if last else list(self._samples)
        if not s:
            return float("nan")
        lq = float(np.mean([x.radiance for x in s]))
        return float(temperature_of(self.calibration.band_um, lq, self.calibration.qe_curve))
