"""Cost of tracking and of the GPS projection: tracker per frame on 1280x720 (a steady drone,
and a bird in every other frame so the gated re-search runs), projection and stop-detector cost
per call."""

from __future__ import annotations

import time

import numpy as np

from snrmon.acquisition.geo.projection import CameraIntrinsics, Pointing, Site, project_to_pixel
from snrmon.acquisition.stops.detector import StopDetector
from snrmon.acquisition.track.tracker import Tracker

KEY = "tracking"


def _frames(n: int, seed: int, bird: bool) -> np.ndarray:
    rng = np.random.default_rng(seed)
    frames = rng.integers(989, 1012, size=(n, 720, 1280), dtype=np.uint16)
    frames[:, 360, 640] += 80
    if bird:  # in every other frame, 5 rows below the drone: in the search window, not the gate
        frames[1::2, 365, 637] += 400
    return frames


def _tracker_us(bird: bool, budget_s: float) -> float:
    frames = _frames(8, seed=1, bird=bird)
    tracker = Tracker((640, 360))
    for f in _frames(8, seed=2, bird=False):  # anchor the track on the drone first
        tracker.update(f)
    n = 0
    start = time.perf_counter()
    while True:
        for f in frames:
            tracker.update(f)
        n += len(frames)
        elapsed = time.perf_counter() - start
        if elapsed >= budget_s:
            return elapsed / n * 1e6


def _per_call_us(fn, budget_s: float) -> float:
    n = 0
    start = time.perf_counter()
    while True:
        for _ in range(100):
            fn()
        n += 100
        elapsed = time.perf_counter() - start
        if elapsed >= budget_s:
            return elapsed / n * 1e6


def run(duration_s: float) -> dict:
    budget = min(max(duration_s / 4.0, 0.2), 2.0)
    site, pointing = Site(32.38, -106.48, 1200.0), Pointing(40.0, 8.0, 0.0)
    cam = CameraIntrinsics(0.016, 8e-6, 1280, 720)
    det = StopDetector()
    t = [0]

    def feed() -> None:
        t[0] += 100_000_000
        det.add_range(t[0], 200.0)

    return {
        "tracker_us_per_frame_1280x720": _tracker_us(False, budget),
        "tracker_us_per_frame_gated_1280x720": _tracker_us(True, budget),
        "project_to_pixel_us": _per_call_us(
            lambda: project_to_pixel(site, pointing, cam, 32.381, -106.479, 1230.0), budget
        ),
        "stop_detector_us_per_reading": _per_call_us(feed, budget),
    }
