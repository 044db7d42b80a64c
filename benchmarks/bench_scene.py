"""Scene rendering speed: ms per frame and fps of the MWIR 1280x720 and LWIR 640x480 renders.

One core, the explicit example scenes with fixed-pattern noise, a drone on the flight and the
fresh-noise window (the path a camera process runs); with and without drifting clouds.
"""

from __future__ import annotations

import dataclasses
import time

from snrmon.sim.example_scenes import lwir_example_scene, mwir_example_scene
from snrmon.sim.feed import FlightCameraFeed
from snrmon.sim.flight import FlightConfig
from snrmon.sim.sky import CloudConfig

KEY = "scene"


def _ms_per_frame(feed: FlightCameraFeed, duration_s: float) -> float:
    feed(0)  # build the static background, the bank and the clouds outside the timing
    n, start = 0, time.perf_counter()
    while True:
        feed(1000 + n)
        n += 1
        elapsed = time.perf_counter() - start
        if elapsed >= duration_s and n >= 20:
            return 1e3 * elapsed / n


def run(duration_s: float) -> dict:
    flight = FlightConfig(seed=0)
    each = max(duration_s / 4.0, 0.25)
    figures: dict = {}
    for name, scene, fps in (
        ("mwir_1280x720", mwir_example_scene(), 60.0),
        ("lwir_640x480", lwir_example_scene(), 30.0),
    ):
        for variant, config in (
            ("", scene),
            (
                "_clouds",
                dataclasses.replace(scene, clouds=CloudConfig(contrast_e=2e5)),
            ),
        ):
            ms = _ms_per_frame(FlightCameraFeed(config, flight, fps=fps, seed=1), each)
            figures[f"{name}{variant}_ms_per_frame"] = round(ms, 3)
            figures[f"{name}{variant}_fps"] = round(1e3 / ms, 1)
    return figures


if __name__ == "__main__":
    print(run(2.0))
