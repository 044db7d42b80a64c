"""Shared test helpers: picklable render callables for camera processes, event waits."""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path

import numpy as np

H, W = 96, 128
SPOT_X, SPOT_Y = 64.3, 40.6
AMPLITUDE_DN = 120.0
NOISE_DN = 6.0


class SpotOnNoise:
    """Picklable render callable: a Gaussian spot (sigma 0.7 px) on 1000 DN of white noise,
    optionally over a fixed pattern of ``fpn_dn`` and appearing only from frame ``spot_from``."""

    def __init__(self, seed: int, *, fpn_dn: float = 0.0, spot_from: int = 0) -> None:
        self.seed = seed
        self.spot_from = spot_from
        yy, xx = np.mgrid[0:H, 0:W]
        self.spot = AMPLITUDE_DN * np.exp(-((xx - SPOT_X) ** 2 + (yy - SPOT_Y) ** 2) / (2 * 0.7**2))
        # A fixed per-pixel offset pattern (fixed-pattern noise), the same in every frame.
        self.fpn = np.random.default_rng([seed, 999]).normal(0.0, fpn_dn, (H, W)) if fpn_dn else 0

    def __call__(self, counter: int) -> np.ndarray:
        rng = np.random.default_rng([self.seed, counter])
        spot = self.spot if counter >= self.spot_from else 0.0
        frame = 1000.0 + self.fpn + spot + rng.normal(0.0, NOISE_DN, (H, W))
        return np.clip(np.rint(frame), 0, 65535).astype(np.uint16)


def wait_until(predicate, timeout_s: float, what: str) -> None:
    cond = threading.Condition()
    deadline = time.monotonic() + timeout_s
    with cond:
        while not predicate():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out waiting for {what}")
            cond.wait(0.02)


def sensor_toml(path: Path, fps: float = 60.0) -> Path:
    """The LWIR preset, resized to the test cameras' format (W x H) at ``fps``: a sensor the
    model accepts for a simulated camera of this size."""
    from model.presets import PRESET_DIR

    lines = []
    for line in (PRESET_DIR / "lwir.toml").read_text().splitlines():
        key = line.split("=")[0].strip()
        value = {"width_px": W, "height_px": H, "fps": fps}.get(key)
        lines.append(f"{key} = {value}" if value is not None else line)
    path.write_text("\n".join(lines) + "\n")
    return path


def strict_json(text: str):
    """Parse like a strict RFC 8259 parser: NaN and Infinity are errors (Python's json module
    accepts them by default), and so is anything but one document."""

    def refuse(name: str):
        raise ValueError(f"{name} is not JSON")

    return json.loads(text, parse_constant=refuse)
