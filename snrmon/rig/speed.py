"""``snrmon hil --speed max``: the fastest flight speed this machine sustains without dropping a
frame.

The console's time base is the host's monotonic clock at receipt (docs/architecture.md, "Time"):
every reading and frame is stamped when it arrives, the stop detector and the 100-frame windows run
on those stamps, and the serial protocols (LDM, NMEA) carry no clock the console could follow
instead. So a HIL flight cannot run "unpaced"; it runs paced at ``speed`` x real time (the cameras
at ``fps x speed``), and ``max`` is the largest speed whose load fits this machine.

It is measured, not guessed: the same rig (camera processes, serial simulators, Session with the
ROI on the drone) runs at speed 1 for a few seconds while the CPU time of the console process
and of each camera process is read (psutil). CPU per second of flight scales with the speed, so
the speed is the smallest of: each camera process within ``RENDER_SHARE`` of a core, the console
(one process: its threads share the GIL) within ``CONSOLE_SHARE`` of a core, everything within
``TOTAL_SHARE`` of the machine's cores, and ``MAX_SPEED``. The shares leave room for recording,
a display, the operating system and the machine's other work.

With a recording (``--out``) the disk is measured too: the probe records (its CPU is then part of
the console's load), and a plain sequential write past the write cache
(:func:`snrmon.acquisition.record.disk_speed.sequential_write`) gives what the disk sustains; the
cameras' data rate at the chosen speed stays within ``RECORD_SHARE`` of it, so the recorder's
backlog never fills on a steady disk.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import psutil

from snrmon.acquisition.record.disk_speed import sequential_write

RENDER_SHARE = 0.7  # of one core per camera process
CONSOLE_SHARE = 0.6  # of one core for the console process (GIL-bound)
TOTAL_SHARE = 0.7  # of all cores
MAX_SPEED = 8.0  # the serial devices' 10 Hz must still give each stop a few readings
PROBE_S = 3.0
RECORD_SHARE = 0.7  # of the disk's sustained sequential write


@dataclass(frozen=True)
class SpeedChoice:
    """The chosen speed and the loads at speed 1 it was chosen from (fractions of a core; with a
    recording, the disk's sustained MB/s and the cameras' MB/s at speed 1)."""

    speed: float
    console_load: float
    camera_load: dict[str, float]
    cores: int
    disk_mb_per_s: float | None = None
    data_mb_per_s: float | None = None

    def describe(self) -> str:
        cams = ", ".join(f"{c} camera {v:.0%}" for c, v in self.camera_load.items())
        disk = ""
        if self.disk_mb_per_s is not None and self.data_mb_per_s is not None:
            disk = (
                f"; recording: the disk sustains {self.disk_mb_per_s:.0f} MB/s, the cameras "
                f"give {self.data_mb_per_s:.0f} MB/s at speed 1"
            )
        return (
            f"speed max = {self.speed:g} x real time on {self.cores} cores "
            f"(at speed 1: console {self.console_load:.0%} of a core, {cams}{disk})"
        )


def _cpu_s(proc: psutil.Process) -> float:
    t = proc.cpu_times()
    return t.user + t.system


def speed_from_loads(
    console: float,
    cameras: dict[str, float],
    cores: int,
    *,
    disk_mb_per_s: float | None = None,
    data_mb_per_s: float | None = None,
) -> float:
    """The speed that keeps every load within its share (module docstring), rounded down to
    0.1 (at least 0.1). Loads are fractions of one core at speed 1; with a recording, the data
    rate at speed 1 stays within ``RECORD_SHARE`` of the disk's sustained rate."""
    limits = [MAX_SPEED, CONSOLE_SHARE / max(console, 1e-6)]
    if disk_mb_per_s is not None and data_mb_per_s:
        limits.append(RECORD_SHARE * disk_mb_per_s / data_mb_per_s)
    limits += [RENDER_SHARE / max(v, 1e-6) for v in cameras.values()]
    limits.append(TOTAL_SHARE * cores / max(console + sum(cameras.values()), 1e-6))
    return max(math.floor(min(limits) * 10) / 10, 0.1)


def max_speed(opts, *, probe_s: float = PROBE_S) -> SpeedChoice:
    """Measure the loads of the HIL options ``opts`` at speed 1 and choose the speed."""
    from snrmon.rig.rig import HilRig

    out_dir = Path(opts.out).resolve().parent if opts.out else None
    probe_path = None
    if out_dir is not None:  # the probe records too, beside the real recording
        probe_path = out_dir / f".snrmon-speed-probe-{os.getpid()}.h5"
    probe = replace(opts, speed=1.0, out=None if probe_path is None else str(probe_path))
    me = psutil.Process()
    rig_ctx = HilRig(probe)
    try:
        choice = _probe(rig_ctx, me, probe_s)
    finally:
        if probe_path is not None:
            probe_path.unlink(missing_ok=True)
    if out_dir is None:
        return choice
    disk = sequential_write(out_dir)
    data = (
        sum(r.sensor.width_px * r.sensor.height_px * 2 * r.fps for r in rig_ctx.cameras.values())
        / 1e6
    )
    speed = speed_from_loads(
        choice.console_load,
        choice.camera_load,
        choice.cores,
        disk_mb_per_s=disk.mb_per_s,
        data_mb_per_s=data,
    )
    return replace(choice, speed=speed, disk_mb_per_s=disk.mb_per_s, data_mb_per_s=data)


def _probe(rig_ctx, me: psutil.Process, probe_s: float) -> SpeedChoice:
    with rig_ctx as rig:
        deadline = time.monotonic() + 20.0
        # Wait for the first frames of every camera (process start-up is not a load).
        while time.monotonic() < deadline and not all(
            p.status().frames.received > 0 for p in rig.session.pipelines.values()
        ):
            time.sleep(0.05)  # polling a status in a CLI, not a test
        for cam in rig.cameras:
            xy = rig.truth_pixel(cam)
            if xy is not None:
                rig.session.set_roi(cam, int(np.rint(xy[0])), int(np.rint(xy[1])))
        procs = {c: psutil.Process(r.producer.pid) for c, r in rig.cameras.items()}
        t0, me0 = time.monotonic(), _cpu_s(me)
        cam0 = {c: _cpu_s(p) for c, p in procs.items()}
        time.sleep(probe_s)  # the measurement interval
        wall = time.monotonic() - t0
        console = (_cpu_s(me) - me0) / wall
        cameras = {c: (_cpu_s(p) - cam0[c]) / wall for c, p in procs.items()}
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    cores = int(cores or 1)
    return SpeedChoice(speed_from_loads(console, cameras, cores), console, cameras, cores)
