"""Shared-memory camera throughput: a 1280x720 uint16 writer process -> ShmCamera reader.

Three runs of up to a third of min(duration_s, 10) each: free-running with a new array per frame
(the default), free-running with 4 reused buffers, and paced at 60 fps (the MWIR rate), where
the figures that matter are the achieved rate, the drops and the writer-to-reader latency.
"""

from __future__ import annotations

import os
import threading
import time
import uuid

import numpy as np

from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.camera.shm import ShmCamera
from snrmon.sim.devices.shm_camera import ShmProducer, StampPattern

KEY = "camera_shm"
W, H = 1280, 720


def _run_once(fps: float | None, seconds: float, reuse_buffers: int) -> dict:
    name = f"snrmbench_{os.getpid()}_{uuid.uuid4().hex[:6]}"
    lat_ns: list[int] = []
    first = threading.Event()

    def on_frame(frame: Frame) -> None:
        lat_ns.append(frame.t_host_ns - frame.meta["t_write_ns"])
        first.set()

    prod = ShmProducer(name, W, H, StampPattern(W, H), fps=fps, slots=8)
    prod.start()
    cam = ShmCamera("bench", name, reuse_buffers=reuse_buffers)
    cam.subscribe(on_frame)
    try:
        cam.open()
        if not first.wait(10):
            raise OSError("no frame from the shm writer within 10 s")
        n0, w0, d0, t0 = len(lat_ns), prod.frames_written, cam.status().dropped, time.monotonic()
        time.sleep(seconds)  # the measurement interval itself, not synchronisation
        n1, w1, d1, t1 = len(lat_ns), prod.frames_written, cam.status().dropped, time.monotonic()
        overruns = cam.frames_lost_to_overrun
    finally:
        cam.close()
        prod.close()
    lat = np.array(lat_ns[n0:n1], float) / 1e6
    return {
        "delivered_fps": (n1 - n0) / (t1 - t0),
        "written_fps": (w1 - w0) / (t1 - t0),
        "dropped": d1 - d0,
        "lost_to_overrun": overruns,
        "latency_median_ms": float(np.median(lat)) if lat.size else float("nan"),
        "latency_p99_ms": float(np.percentile(lat, 99)) if lat.size else float("nan"),
    }


def run(duration_s: float) -> dict:
    each = min(duration_s, 10.0) / 3
    free = _run_once(None, each, 0)
    reuse = _run_once(None, each, 4)
    paced = _run_once(60.0, each, 0)
    return {
        "frame_MB": W * H * 2 / 1e6,
        "free_delivered_fps": free["delivered_fps"],
        "free_written_fps": free["written_fps"],
        "free_dropped": free["dropped"],
        "free_latency_median_ms": free["latency_median_ms"],
        "free_reuse4_delivered_fps": reuse["delivered_fps"],
        "free_reuse4_dropped": reuse["dropped"],
        "paced60_delivered_fps": paced["delivered_fps"],
        "paced60_dropped": paced["dropped"],
        "paced60_latency_median_ms": paced["latency_median_ms"],
        "paced60_latency_p99_ms": paced["latency_p99_ms"],
        "seconds_per_run": each,
    }
