"""The 3D noise of a recorded camera's background (:mod:`snrmon.acquisition.measure.noise3d`): over
a span of its frames, or over a stop's summary frames in the region clear of the target.

A stop's background is measured on the frames its SNR summarises (paper section 7: the first
100 consecutive valid frames, :func:`snrmon.acquisition.stops.detector.summarise_stop`), in the
largest rectangle of the frame clear of every peak of those frames by
:data:`~snrmon.acquisition.measure.background.CLEAR_MARGIN_PX` plus half the largest segmented
extent (:func:`~snrmon.acquisition.measure.background.clear_region`): raw recorded pixels, the
camera's own noise and fixed pattern. The same function serves the report (the replay's
measurements) and ``snrmon noise --stop`` (the recorded ones; the same in an exact replay).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from snrmon.acquisition.measure.background import (
    CLEAR_MARGIN_PX,
    Rect,
    clear_region,
    target_box,
)
from snrmon.acquisition.measure.noise3d import Noise3d, Noise3dSums
from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.record.reader import CameraRecord
from snrmon.acquisition.record.stream_rows import peak_snr_from_row
from snrmon.acquisition.stops.detector import summarise_stop

_READ_FRAMES = 64  # frames read from the file at a time


@dataclass(frozen=True)
class StopNoise:
    """The 3D noise of one stop's background for one camera: ``frames`` the first and last frame
    (indices in the file) of the summary run, ``region`` (x0, y0, x1, y1, corners included)."""

    camera: str
    stop: int
    range_m: float | None
    frames: tuple[int, int]
    region: Rect
    noise: Noise3d


def region_sums(
    cam: CameraRecord, frame_index: Sequence[int] | np.ndarray, region: Rect
) -> Noise3dSums:
    """The marginal sums of ``region`` of the frames ``frame_index`` (increasing indices in the
    file), read a block at a time (only the region's pixels)."""
    x0, y0, x1, y1 = region
    idx = np.asarray(frame_index, dtype=np.int64)
    sums = Noise3dSums(y1 - y0 + 1, x1 - x0 + 1)
    for i in range(0, idx.size, _READ_FRAMES):
        part = idx[i : i + _READ_FRAMES]
        if part[-1] - part[0] + 1 == part.size:  # contiguous: one slice
            block = cam.frames[int(part[0]) : int(part[-1]) + 1, y0 : y1 + 1, x0 : x1 + 1]
        else:
            block = cam.frames[part.tolist(), y0 : y1 + 1, x0 : x1 + 1]
        sums.add(np.asarray(block))
    return sums


def background_region(
    shape: tuple[int, int], results: Sequence[PeakSnr], *, margin_px: int = CLEAR_MARGIN_PX
) -> Rect | None:
    """The largest region of a frame of ``shape`` clear of every peak of ``results`` (widened
    by half the largest segmented extent); None when none is 2 x 2 pixels."""
    if not results:
        return None
    peaks = [(r.peak_x, r.peak_y) for r in results]
    half = max(max(r.extent_w_px, r.extent_h_px) for r in results) // 2
    return clear_region(shape, target_box(shape, peaks, margin_px=margin_px, half_extent_px=half))


def summary_run(
    cam: CameraRecord,
    results: Sequence[PeakSnr],
    t_host_ns: Sequence[int] | np.ndarray,
    n: int = 100,
) -> tuple[np.ndarray, list[PeakSnr]]:
    """The frames (indices in the file) and results of the summary run of a stop's measurements
    ``results`` at times ``t_host_ns``; measurements whose frame the file lacks are left out."""
    summary = summarise_stop(results, n)
    if summary.first is None:
        return np.zeros(0, np.int64), []
    lo, hi = summary.first, summary.first + summary.n_frames
    times = np.asarray(t_host_ns, dtype=np.int64)[lo:hi]
    pos = np.searchsorted(cam.t_host_ns, times)
    found = (pos < cam.n_frames) & (cam.t_host_ns[np.minimum(pos, cam.n_frames - 1)] == times)
    return pos[found], [r for r, ok in zip(results[lo:hi], found, strict=True) if ok]


def stop_noise(
    cam: CameraRecord,
    stop: int,
    range_m: float | None,
    results: Sequence[PeakSnr],
    t_host_ns: Sequence[int] | np.ndarray,
    *,
    n: int = 100,
) -> StopNoise | None:
    """The 3D noise of one stop's background (module docstring) from the camera's measurements
    during the stop; None when the stop has no valid frame, or no region is clear."""
    index, run = summary_run(cam, results, t_host_ns, n)
    region = background_region((int(cam.frames.shape[1]), int(cam.frames.shape[2])), run)
    if region is None or index.size < 2:
        return None
    noise = region_sums(cam, index, region).result()
    return StopNoise(cam.name, stop, range_m, (int(index[0]), int(index[-1])), region, noise)


def recorded_stop_run(
    cam: CameraRecord, t_start_ns: int, t_end_ns: int | None, n: int = 100
) -> tuple[np.ndarray, list[PeakSnr]]:
    """:func:`summary_run` of the measurements the live session recorded during a stop."""
    rows = cam.measurements
    t = rows["t_host_ns"]
    keep = t >= t_start_ns
    if t_end_ns is not None:
        keep &= t < t_end_ns
    picked = rows[keep]
    return summary_run(cam, [peak_snr_from_row(r) for r in picked], picked["t_host_ns"], n)
