"""Shared test helpers: picklable render callables for camera processes, event waits."""

from __future__ import annotations

import threading
import time

import numpy as np

H, W = 96, 128
SPOT_X, SPOT_Y = 64.3, 40.6
AMPLITUDE_DN = 120.0
NOISE_DN = 6.0


class SpotOnNoise:
    """Picklable render callable: a Gaussian spot (sigma 0.7 px) on 1000 DN of white noise."""

    def __init__(self, seed: int) -> None:
        self.seed = seed
        yy, xx = np.mgrid[0:H, 0:W]
        self.spot = AMPLITUDE_DN * np.exp(-((xx - SPOT_X) ** 2 + (yy - SPOT_Y) ** 2) / (2 * 0.7**2))

    def __call__(self, counter: int) -> np.ndarray:
        rng = np.random.default_rng([self.seed, counter])
        frame = 1000.0 + self.spot + rng.normal(0.0, NOISE_DN, (H, W))
        return np.clip(np.rint(frame), 0, 65535).astype(np.uint16)


def wait_until(predicate, timeout_s: float, what: str) -> None:
    cond = threading.Condition()
    deadline = time.monotonic() + timeout_s
    with cond:
        while not predicate():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out waiting for {what}")
            cond.wait(0.02)
