"""The recording disk: its measured sequential write speed against the cameras' data rate, and
its free space against the planned duration.

The speed is measured, not looked up: ``n_bytes`` of incompressible data written in 8 MiB
blocks to a temporary file in the recording folder and ``fsync``-ed, so the page cache does not
pass for the disk (the time includes the flush). The recorder sustains about 0.66 of a plain
sequential write on the same disk (README, "Performance"), so the disk must write at least
:data:`SPEED_MARGIN` times the cameras' raw rate.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from snrmon.doctor import FAIL, PASS, SKIP, Check

BLOCK_BYTES = 8 * 2**20
SPEED_MARGIN = 2.0  # 1 / 0.66 for the recorder's own overhead, and room for the rest of the day
SPACE_MARGIN = 1.05  # HDF5 metadata, measurements, streams and the log beside the file
MB = 1e6


def measure_write_speed(
    directory: str | Path, n_bytes: int, *, write: Callable[[int, bytes], int] = os.write
) -> float:
    """Bytes per second of a sequential, fsync-ed write of ``n_bytes`` in ``directory``
    (``write`` is ``os.write``; tests pass a slower one to simulate a slow disk)."""
    block = np.random.default_rng(0).integers(0, 256, BLOCK_BYTES, dtype=np.uint8).tobytes()
    fd, name = tempfile.mkstemp(prefix=".snrmon-doctor-", dir=directory)
    try:
        t0 = time.perf_counter()
        left = n_bytes
        while left > 0:
            chunk = block if left >= len(block) else block[:left]
            left -= write(fd, chunk)
        os.fsync(fd)
        elapsed = time.perf_counter() - t0
    finally:
        os.close(fd)
        os.unlink(name)
    return n_bytes / max(elapsed, 1e-9)


def check_disk_speed(
    directory: str | Path,
    rate_bytes_per_s: float | None,
    n_bytes: int,
    *,
    write: Callable[[int, bytes], int] = os.write,
) -> Check:
    """Measured write speed of ``directory``'s disk against ``SPEED_MARGIN`` x the rate."""
    speed = measure_write_speed(directory, n_bytes, write=write)
    data = {"write_mb_s": speed / MB, "needed_mb_s": None, "test_mb": n_bytes / MB}
    shown = f"{directory}: sequential write {speed / MB:.0f} MB/s ({n_bytes / MB:.0f} MB, fsync)"
    if rate_bytes_per_s is None:
        return Check(
            "disk-speed",
            SKIP,
            f"{shown}; no cameras configured to compare with",
            needed=False,
            data=data,
        )
    need = rate_bytes_per_s * SPEED_MARGIN
    data["needed_mb_s"] = need / MB
    compare = (
        f"the cameras' {rate_bytes_per_s / MB:.1f} MB/s x {SPEED_MARGIN:g} margin = "
        f"{need / MB:.0f} MB/s"
    )
    if speed < need:
        return Check(
            "disk-speed",
            FAIL,
            f"{shown}: slower than {compare}",
            "record to a faster disk (an internal SSD/NVMe, not a USB 2 stick or a "
            "network share), or record fewer cameras",
            data=data,
        )
    return Check("disk-speed", PASS, f"{shown}: enough for {compare}", data=data)


def frames_ratio(config, samples: dict) -> tuple[str, float] | None:
    """``(filter, ratio)``: how the cameras' own frames (``samples``, from the device checks)
    compress with the config's filter, measured (raw / stored bytes, all cameras' frames
    together); None when no camera gave a frame (the space check then counts raw bytes)."""
    if config is None or not samples:
        return None
    from snrmon.acquisition.compression import measured_ratio, stored_compression

    frames = [f for name in sorted(samples) for f in samples[name]]
    return config.compression, measured_ratio(frames, stored_compression(config.compression))


def check_free_space(
    directory: str | Path,
    rate_bytes_per_s: float | None,
    duration_s: float,
    *,
    compression: tuple[str, float] | None = None,
    usage: Callable[[str | Path], shutil._ntuple_diskusage] = shutil.disk_usage,
) -> Check:
    """Free space in ``directory`` against ``duration_s`` of the cameras' data, the frames at
    their measured ``compression`` = (filter, ratio) (None: not measured, raw bytes)."""
    free = usage(directory).free
    data = {"free_gb": free / 1e9, "needed_gb": None, "duration_s": duration_s}
    data["compression"], data["compression_ratio"] = compression or (None, None)
    if rate_bytes_per_s is None:
        return Check(
            "disk-space",
            SKIP,
            f"{directory}: {free / 1e9:.1f} GB free; no cameras configured to compare with",
            needed=False,
            data=data,
        )
    how = "raw: compression not measured"
    if compression is not None:
        rate_bytes_per_s /= compression[1]
        how = f"{compression[0]} {compression[1]:.2f}x, measured on the cameras' frames"
    need = rate_bytes_per_s * duration_s * SPACE_MARGIN
    data["needed_gb"] = need / 1e9
    hours = duration_s / 3600
    shown = (
        f"{directory}: {free / 1e9:.1f} GB free; {hours:.2f} h at "
        f"{rate_bytes_per_s / MB:.1f} MB/s ({how}) needs {need / 1e9:.1f} GB"
    )
    if free < need:
        fits_h = free / SPACE_MARGIN / rate_bytes_per_s / 3600
        return Check(
            "disk-space",
            FAIL,
            f"{shown}: room for only {fits_h:.2f} h",
            "free space on this disk, record to a bigger one (--record-dir), or plan "
            "shorter recordings (--duration)",
            data=data,
        )
    return Check("disk-space", PASS, shown, data=data)


def cameras_rate(config, formats: dict) -> float | None:
    """Bytes per second of all configured cameras: the format each negotiated when it answered,
    else its config size or sensor preset (16-bit pixels); the rate it negotiated, else its
    sensor preset's. A camera with neither is left out (its own check says why)."""
    if config is None or not config.cameras:
        return None
    from snrmon.model.presets import load_sensor

    total = 0.0
    for cam in config.cameras:
        fmt = formats.get(cam.name)
        try:
            sensor = load_sensor(cam.sensor)
        except (ValueError, OSError):
            sensor = None
        fps = (fmt.fps if fmt is not None else None) or (sensor.fps if sensor else None)
        if fmt is not None:
            frame_bytes = fmt.bytes_per_frame
        elif sensor is not None:
            w, h = cam.width_px or sensor.width_px, cam.height_px or sensor.height_px
            frame_bytes = w * h * 2
        else:
            continue
        if fps:
            total += frame_bytes * fps
    return total or None
