"""Cost of the Eq. (4) measurement: per-frame path on 640x480 and 1280x720 frames (it reads only
the search window and box, so the two must cost the same), and the stack path's throughput."""

from __future__ import annotations

import time

import numpy as np

from snrmon.acquisition.measure.peak_snr import PeakSnrMeter
from snrmon.acquisition.measure.stack_snr import measure_stack

KEY = "measurement"


def _frames(shape: tuple[int, ...], seed: int) -> np.ndarray:
    # Uniform integer noise: the cost does not depend on the values, and a float64 Gaussian
    # stack of 300 HD frames would take seconds and gigabytes just to make.
    rng = np.random.default_rng(seed)
    frames = rng.integers(989, 1012, size=shape, dtype=np.uint16)
    y, x = shape[-2] // 2, shape[-1] // 2
    frames[..., y, x] += 80
    return frames


def _per_frame_us(shape: tuple[int, int], budget_s: float) -> float:
    frames = _frames((8, *shape), seed=1)
    at = (shape[1] // 2 + 2, shape[0] // 2 - 1)
    meter = PeakSnrMeter()
    for f in frames:  # warm-up
        meter.measure(f, at)
    n = 0
    start = time.perf_counter()
    while True:
        for f in frames:
            meter.measure(f, at)
        n += len(frames)
        elapsed = time.perf_counter() - start
        if elapsed >= budget_s:
            return elapsed / n * 1e6


def _stack_fps(n_frames: int, budget_s: float) -> float:
    stack = _frames((n_frames, 720, 1280), seed=2)
    at = (642, 359)
    measure_stack(stack[:10], at)
    runs = 0
    start = time.perf_counter()
    while True:
        measure_stack(stack, at)
        runs += 1
        elapsed = time.perf_counter() - start
        if elapsed >= budget_s:
            return runs * n_frames / elapsed


def run(duration_s: float) -> dict:
    budget = min(max(duration_s / 4.0, 0.2), 2.0)
    return {
        "per_frame_us_640x480": _per_frame_us((480, 640), budget),
        "per_frame_us_1280x720": _per_frame_us((720, 1280), budget),
        "stack_fps_300x720x1280": _stack_fps(300, budget),
    }
