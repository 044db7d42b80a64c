"""The frames' lossless filters: bytes per frame, compression ratio, the writer's CPU per frame
and the time ``replay --fast`` takes to get a frame (``replay_read_ms_per_frame``), on
the twin's frames and on real camera frames; and which filter keeps up.

Each filter (``none`` and every one of ``acquisition/record/writer.COMPRESSIONS``) records the
same frames through the recorder's own writer (:class:`SessionWriter`, the code the writer thread
runs: one chunk per frame, then the flush), timed with the thread's CPU clock, so the figure is
the filter's cost and not the disk's (no ``fsync``; the disk's speed is the ``recorder``
benchmark's).

- **the twin**: the simulated day's cameras (``snrmon hil``: the twin of the MWIR 1280x720 and
  LWIR 640x480 presets, fixed pattern, shot noise, the drone on its flight), ``FRAMES`` frames
  each, a second apart in flight time;
- **real frames**: the two Cedip Jade recordings in ``tests/data/pyradi`` (100 frames each, MWIR
  64x69, LWIR 68x75, 16-bit counts: ``$SNRMON_TEST_DATA/pyradi`` in an installed package).
  Small frames: their ratio says how real sensor noise compresses; their CPU per frame is
  dominated by the per-chunk overhead, so "keeps up" is judged on the twin's full-size frames.

``<filter>_both_cameras_core`` is the writer's CPU for one second of both cameras (MWIR at 60
fps, LWIR at 30) as a fraction of one core; ``<filter>_twin_size`` the twin's bytes over their
raw size. ``chosen`` applies the recorder's rule (``writer.DEFAULT_COMPRESSION``): of the filters
within :data:`MAX_SIZE` of the raw size, the one with the least writer CPU, if it takes at most
:data:`MAX_CORE` of one core.
"""

from __future__ import annotations

import os
import tempfile
import time
from pathlib import Path

import numpy as np

from snrmon.acquisition.compression import frame_filter, stored_compression
from snrmon.acquisition.record.writer import SessionWriter
from snrmon.acquisition.streams.timebase import ClockMap
from snrmon.benchmarks.real_clips import data_root
from snrmon.limits import COMPRESSION_CHOICES, DEFAULT_COMPRESSION

KEY = "compression"
FRAMES = 24
CROP_PX = 64  # the square a fast replay reads around the target (the tracker's window)
TWIN_CAMERAS = (("mwir", 60.0), ("lwir", 30.0))
MAX_SIZE = 0.45  # the goals (goals.py) hold the default to the same two figures
"""The default filter keeps a day at most this fraction of its raw size."""
MAX_CORE = 0.5
"""... and its writer takes at most this fraction of one core for both cameras (the rest of the
core is the writer's HDF5 bookkeeping and whatever shares the core)."""


def twin_frames(camera: str, n: int = FRAMES, seed: int = 5) -> np.ndarray:
    """``n`` frames (N, H, W) uint16 of the simulated day's ``camera`` (its twin, as ``snrmon
    hil`` renders it), one a second of flight time apart from take-off."""
    from snrmon.model.presets import load_sensor, load_target
    from snrmon.sim.feed import FlightCameraFeed
    from snrmon.sim.flight import FlightConfig
    from snrmon.sim.twin import Scenario, twin_scene_config

    sensor = load_sensor(camera)
    scene = twin_scene_config(sensor, load_target("uav1"), Scenario())
    feed = FlightCameraFeed(scene, FlightConfig(seed=seed), fps=sensor.fps, seed=seed)
    step = max(1, round(sensor.fps))
    return np.stack([feed(k * step) for k in range(n)]).astype(np.uint16)


def real_frames() -> dict[str, np.ndarray]:
    """The real ``.ptw`` recordings' frames by camera (an empty dict when the data is absent)."""
    from snrmon.acquisition.replay.ptw import load_ptw

    out = {}
    for camera, name in (("mwir", "PyradiSampleMWIR.ptw"), ("lwir", "PyradiSampleLWIR.ptw")):
        path = data_root("pyradi") / name
        if path.is_file():
            out[camera] = np.ascontiguousarray(load_ptw(path)[0])
    return out


def filter_figures(frames: np.ndarray, compression: str, directory: Path) -> dict:
    """``frames`` through the recorder's writer with ``compression``: bytes per frame (the
    frames' dataset as stored), ratio (raw / stored) and the writer's CPU ms per frame."""
    path = directory / f"{compression}-{frames.shape[1]}x{frames.shape[2]}.h5"
    stored = stored_compression(compression)
    writer = SessionWriter(
        path,
        config={"bench": True},
        shapes={"cam": frames.shape[1:]},
        filters=frame_filter(stored),
        compression=stored,
        clock=ClockMap(),
        flush_interval_s=0.5,
        fsync=False,
    )
    try:
        cpu0 = time.thread_time()
        for i, pixels in enumerate(frames):
            writer.write_frame("cam", pixels, i, i, -1)
        writer.flush()
        cpu = time.thread_time() - cpu0
        stored_bytes = writer.frames_bytes_stored("cam")
        writer.close()
        read_s = _replay_read_seconds(path, len(frames))
    finally:
        writer.close()
        path.unlink(missing_ok=True)
    n = len(frames)
    return {
        "bytes_per_frame": stored_bytes / n,
        "ratio": frames.nbytes / max(1, stored_bytes),
        "cpu_ms_per_frame": 1e3 * cpu / n,
        "replay_read_ms_per_frame": 1e3 * read_s / n,
    }


def _replay_read_seconds(path: Path, n: int) -> float:
    """Seconds to get each of the ``n`` frames as ``replay --fast`` hands them to the engine
    and touch a CROP_PX square of it (the track's): a view into a memory map when raw, the
    frame decompressed whole through h5py when filtered (acquisition/replay/feeder.py)."""
    import h5py

    from snrmon.acquisition.record.frame_access import FrameCrops

    with h5py.File(path, "r") as f:
        frames = f["cameras/cam/frames"]
        h, w = frames.shape[1:]
        y0, x0 = max(0, h // 2 - CROP_PX // 2), max(0, w // 2 - CROP_PX // 2)
        crops = FrameCrops(frames)
        t0 = time.perf_counter()
        for i in range(n):
            view = crops.frame_view(i)
            pixels = frames[i] if view is None else view
            pixels[y0 : y0 + CROP_PX, x0 : x0 + CROP_PX].sum()
        return time.perf_counter() - t0


def chosen_filter(figures: dict) -> str | None:
    """The recorder's rule on these figures: of the filters within MAX_SIZE of the raw size, the
    one with the least writer CPU for both cameras, if it takes at most MAX_CORE of a core."""
    fits = [
        c
        for c in COMPRESSION_CHOICES
        if figures.get(f"{_key(c)}_twin_size", 1.0) <= MAX_SIZE
        and figures.get(f"{_key(c)}_both_cameras_core", 1.0) <= MAX_CORE
    ]
    return min(fits, key=lambda c: figures[f"{_key(c)}_both_cameras_core"], default=None)


def _key(compression: str) -> str:
    return compression.replace("-", "_")


def run(duration_s: float) -> dict:
    twin = {camera: twin_frames(camera) for camera, _ in TWIN_CAMERAS}
    real = real_frames()
    out: dict = {}
    with tempfile.TemporaryDirectory(
        prefix="snrmon-bench-", dir=os.environ.get("SNRMON_BENCH_DIR")
    ) as tmp:
        for compression in COMPRESSION_CHOICES:
            key = _key(compression)
            core = raw = stored = 0.0
            for camera, fps in TWIN_CAMERAS:
                f = filter_figures(twin[camera], compression, Path(tmp))
                for name, value in f.items():
                    out[f"{key}_twin_{camera}_{name}"] = round(value, 4)
                core += fps * f["cpu_ms_per_frame"] / 1e3
                raw += fps * twin[camera][0].nbytes
                stored += fps * f["bytes_per_frame"]
            out[f"{key}_both_cameras_core"] = round(core, 4)
            out[f"{key}_twin_size"] = round(stored / raw, 4)
            for camera, frames in real.items():
                f = filter_figures(frames, compression, Path(tmp))
                for name, value in f.items():
                    out[f"{key}_ptw_{camera}_{name}"] = round(value, 4)
    if not real:
        out["ptw"] = f"not measured: {data_root('pyradi')} not found"
    out["chosen"] = chosen_filter(out)
    out["default"] = DEFAULT_COMPRESSION
    return out


if __name__ == "__main__":
    import json

    print(json.dumps(run(1.0), indent=2))
