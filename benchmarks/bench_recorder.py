"""Recorder throughput against a plain sequential write of the same bytes to the same disk.

Both sides write MWIR-sized frames (1280x720 uint16, sky-like: a gradient plus seeded noise, so
that compression ratios mean something) into a temporary directory (``$SNRMON_BENCH_DIR`` or the
system's), and both ``fsync`` every 0.5 s as the recorder does, so the page cache does not flatter
either. The recorder is fed as fast as its backlog allows. With hdf5plugin installed, each
lossless filter is measured too: its compression ratio, throughput and CPU per frame.
"""

from __future__ import annotations

import os
import shutil
import statistics
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from acquisition.record.recorder import SessionRecorder
from acquisition.record.writer import COMPRESSIONS
from drivers.camera.frame import Frame

KEY = "recorder"
H, W = 720, 1280
MB = 1e6


def _frames(n: int = 8) -> list[np.ndarray]:
    rng = np.random.default_rng(2019)
    yy, xx = np.mgrid[0:H, 0:W]
    sky = 2000.0 + 0.3 * yy + 0.05 * xx
    return [np.round(sky + rng.normal(0, 8, (H, W))).astype(np.uint16) for _ in range(n)]


def _raw_write(path: Path, frames: list[np.ndarray], seconds: float) -> tuple[float, int]:
    """MB/s of a plain sequential write (with an fsync every 0.5 s) and the bytes written."""
    written = 0
    with open(path, "wb", buffering=0) as fh:
        t0 = next_sync = time.perf_counter()
        i = 0
        while time.perf_counter() - t0 < seconds:
            written += fh.write(frames[i % len(frames)].data)
            i += 1
            if time.perf_counter() >= next_sync:
                os.fsync(fh.fileno())
                next_sync += 0.5
        os.fsync(fh.fileno())
        elapsed = time.perf_counter() - t0
    return written / MB / elapsed, written


def _record(
    path: Path, frames: list[np.ndarray], seconds: float, compression: str | None
) -> dict[str, float]:
    """Feed the recorder for ``seconds`` as fast as its backlog drains; throughput and costs."""
    rec = SessionRecorder(
        path,
        config={"bench": True},
        cameras={"mwir": (H, W)},
        compression=compression,
        max_backlog_bytes=16 * frames[0].nbytes,
    )
    pause = threading.Event()
    cpu0, t0 = time.process_time(), time.perf_counter()
    i = dropped = 0
    while time.perf_counter() - t0 < seconds:
        if (
            rec.add_frame("mwir", Frame(frames[i % len(frames)], "mwir", i, time.monotonic_ns()))
            is None
        ):
            dropped += 1
            pause.wait(0.005)  # backlog full: the recorder is the bottleneck, as intended here
        i += 1
    summary = rec.stop()
    elapsed = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    n = summary.frames_written["mwir"]
    raw_bytes = n * frames[0].nbytes
    return {
        "mb_per_s": raw_bytes / MB / elapsed,
        "ratio_vs_raw_bytes": raw_bytes / max(1, summary.bytes_written),
        "cpu_ms_per_frame": 1e3 * cpu / max(1, n),
        "frames": float(n),
        "mb": raw_bytes / MB,
        "s": elapsed,
        "error": summary.error,
    }


def run(duration_s: float) -> dict:
    budget = min(duration_s, 10.0)
    try:
        import hdf5plugin  # noqa: F401

        filters = [c for c in COMPRESSIONS if c != "gzip"]
    except ImportError:
        filters = []
    frames = _frames(4)
    tmp = Path(tempfile.mkdtemp(prefix="snrmon-bench-", dir=os.environ.get("SNRMON_BENCH_DIR")))
    try:
        # Raw and recorder slices alternate in pairs so that both see the same disk weather (a
        # shared VM disk swings by 3x within seconds, and its write-back cache makes whichever
        # slice comes first after a quiet spell several times faster); which goes first
        # alternates too, and the ratio is the median of the pairs' ratios. Files are deleted
        # only at the end, since on a disk mounted with "discard" an unlink slows the next
        # slice down.
        seconds = 0.55 * budget / 6
        raw_s, raw_mb, rec_runs = [], [], []

        def raw_slice(k: int) -> None:
            mb_s, nbytes = _raw_write(tmp / f"raw{k}.bin", frames, seconds)
            raw_s.append(nbytes / MB / mb_s)
            raw_mb.append(nbytes / MB)

        def rec_slice(k: int) -> None:
            rec_runs.append(_record(tmp / f"plain{k}.h5", frames, seconds, None))

        for k in range(3):
            for run_slice in (raw_slice, rec_slice) if k % 2 == 0 else (rec_slice, raw_slice):
                run_slice(k)
        raw_runs = [m / t for m, t in zip(raw_mb, raw_s, strict=True)]
        raw_mb_s = statistics.median(raw_runs)
        pair_ratios = [r["mb_per_s"] / w for r, w in zip(rec_runs, raw_runs, strict=True)]
        rec = {
            "mb_per_s": sum(r["mb"] for r in rec_runs) / sum(r["s"] for r in rec_runs),
            "cpu_ms_per_frame": sum(r["cpu_ms_per_frame"] * r["frames"] for r in rec_runs)
            / max(1.0, sum(r["frames"] for r in rec_runs)),
            "error": next((r["error"] for r in rec_runs if r["error"]), None),
        }
        out: dict = {
            "mb_per_s": rec["mb_per_s"],
            "raw_write_mb_per_s": raw_mb_s,
            "ratio": statistics.median(pair_ratios),
            "ratio_of_totals": rec["mb_per_s"] / (sum(raw_mb) / sum(raw_s)),
            "cpu_ms_per_frame": rec["cpu_ms_per_frame"],
            "mwir_fps_sustained": rec["mb_per_s"] * MB / frames[0].nbytes,
            "raw_write_mb_per_s_runs": ", ".join(f"{v:.0f}" for v in raw_runs),
            "recorder_mb_per_s_runs": ", ".join(f"{r['mb_per_s']:.0f}" for r in rec_runs),
            "dir": str(tmp.parent),
        }
        if rec["error"]:
            out["error"] = rec["error"]
        if not filters:
            out["compression"] = "hdf5plugin not installed: not measured"
        for name in filters:
            c = _record(tmp / f"{name}.h5", frames, 0.25 * budget / len(filters), name)
            key = name.replace("-", "_")
            out[f"{key}_ratio"] = c["ratio_vs_raw_bytes"]
            out[f"{key}_mb_per_s"] = c["mb_per_s"]
            out[f"{key}_cpu_ms_per_frame"] = c["cpu_ms_per_frame"]
        return out
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    import json

    print(json.dumps(run(10.0), indent=2))
