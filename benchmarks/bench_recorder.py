"""Recorder throughput against a plain sequential write of the same bytes to the same disk.

Both sides write MWIR-sized frames (1280x720 uint16, sky-like: a gradient plus seeded noise, so
that compression ratios mean something) into a temporary directory (``$SNRMON_BENCH_DIR`` or the
system's). What makes the two comparable and repeatable:

- **past the write cache**: both ``fsync`` every 0.5 s (as the recorder does) and each slice ends
  with an ``fsync`` whose time is counted, so a slice measures what reached the disk, not the
  page cache;
- **a warm-up first**: ``WARMUP_MB`` (default 1 GB, ``$SNRMON_BENCH_WARMUP_MB``) of plain writes,
  not counted, before the first pair. This VM's disk is a file on its host, whose own write-back
  cache takes the first GB of a run at 1.5-2 GB/s however often the guest fsyncs; without the
  warm-up that burst always fell on the first (plain) slice and made that pair's ratio 0.25-0.57;
- **short slices, many pairs**: each slice writes ``SLICE_MB`` (default 256 MB,
  ``$SNRMON_BENCH_SLICE_MB``); ``PAIRS`` recorder slices (default 12, ``$SNRMON_BENCH_PAIRS``)
  alternate with ``PAIRS + 1`` plain ones (raw, rec, raw, ..., raw), and each recorder slice is
  compared with the mean speed of the plain slices just before and after it, so both sides see
  the same disk weather (a disk that drifts within the run is compared at the recorder slice's
  own time; with pairs of one plain and one recorder slice, the order alternating, a drift made
  every pair's ratio lean one way or the other). The host's disk switches between ~2 GB/s (its
  cache) and 250-550 MB/s (the disk under it) within a run, and a pair that straddles a switch
  gives a ratio of 0.2 or 5:
  three pairs of 1 GB slices gave medians of 0.85, 1.09 and 1.16 in three runs in a row, twelve
  pairs of 256 MB 0.889-0.922 on the same code. Other processes on a shared machine still move a
  run by several per cent (``ratio_iqr`` shows it). Files are deleted only at the end (an unlink
  on a disk mounted with "discard" hands the host back its cache and changes the weather for the
  next slice); a run needs about ``WARMUP_MB + (2 * PAIRS + 1) * SLICE_MB`` (7.4 GB) of free
  space;
- the figure is the **median of the pairs' ratios**, and its repeatability is measured by
  **two repeats taken within the run**: the median of the even pairs and that of the odd pairs
  (``ratio_repeats``), interleaved so that both see the same disk weather, and their difference
  over the figure (``ratio_repeat_spread``, the goal's "repeats within 10 %"). The single pairs'
  spread ((max - min) / median, ``ratio_spread``) and interquartile range over the median
  (``ratio_iqr``) are reported too: one pair straddling a switch of the host's cache makes the
  first large (0.61 in a run whose two repeats were 1.03 and 1.08), which says how loud the
  disk's weather is, not how repeatable the median is.

The guest's page cache is not dropped between slices: with an fsync every 0.5 s it holds a few MB
of dirty data at most, and the swings come from the host, which ``/proc/sys/vm/drop_caches`` in
the guest does not reach.

The recorder is fed as fast as its backlog allows, its frames unfiltered (``compression=None``):
the disk's side. The lossless filters' sizes and CPU are the ``compression`` benchmark's.
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

from snrmon.acquisition.record.recorder import SessionRecorder
from snrmon.drivers.camera.frame import Frame

KEY = "recorder"
H, W = 720, 1280
MB = 1e6
SLICE_MB = float(os.environ.get("SNRMON_BENCH_SLICE_MB", 256))
WARMUP_MB = float(os.environ.get("SNRMON_BENCH_WARMUP_MB", 1024))
PAIRS = int(os.environ.get("SNRMON_BENCH_PAIRS", 12))


def _frames(n: int = 8) -> list[np.ndarray]:
    rng = np.random.default_rng(2019)
    yy, xx = np.mgrid[0:H, 0:W]
    sky = 2000.0 + 0.3 * yy + 0.05 * xx
    return [np.round(sky + rng.normal(0, 8, (H, W))).astype(np.uint16) for _ in range(n)]


def _raw_write(path: Path, frames: list[np.ndarray], mb: float) -> float:
    """MB/s of a plain sequential write of ``mb`` MB (an fsync every 0.5 s and at the end)."""
    written = 0
    with open(path, "wb", buffering=0) as fh:
        t0 = next_sync = time.perf_counter()
        i = 0
        while written < mb * MB:
            written += fh.write(frames[i % len(frames)].data)
            i += 1
            if time.perf_counter() >= next_sync:
                os.fsync(fh.fileno())
                next_sync += 0.5
        os.fsync(fh.fileno())
        elapsed = time.perf_counter() - t0
    return written / MB / elapsed


def _record(path: Path, frames: list[np.ndarray], mb: float) -> dict:
    """Feed the recorder ``mb`` MB of frames as fast as its backlog drains, then stop it (the
    final flush, fsync and close are counted); throughput and costs."""
    rec = SessionRecorder(
        path,
        config={"bench": True},
        cameras={"mwir": (H, W)},
        max_backlog_bytes=16 * frames[0].nbytes,
    )
    pause = threading.Event()
    cpu0, t0 = time.process_time(), time.perf_counter()
    i = accepted = 0
    while accepted * frames[0].nbytes < mb * MB:
        frame = Frame(frames[i % len(frames)], "mwir", i, time.monotonic_ns())
        if rec.add_frame("mwir", frame) is None:
            pause.wait(0.002)  # backlog full: the recorder is the bottleneck, as intended here
        else:
            accepted += 1
        i += 1
    summary = rec.stop()
    elapsed = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    n = summary.frames_written["mwir"]
    raw_bytes = n * frames[0].nbytes
    return {
        "mb_per_s": raw_bytes / MB / elapsed,
        "cpu_ms_per_frame": 1e3 * cpu / max(1, n),
        "error": summary.error,
    }


def run(duration_s: float) -> dict:
    frames = _frames(4)
    tmp = Path(tempfile.mkdtemp(prefix="snrmon-bench-", dir=os.environ.get("SNRMON_BENCH_DIR")))
    try:
        warmup = _raw_write(tmp / "warmup.bin", frames, WARMUP_MB) if WARMUP_MB > 0 else None
        # raw, rec, raw, rec, ..., raw: each recorder slice against the plain writes just
        # before and after it (their mean speed), so a disk whose speed drifts within the run
        # is compared at the recorder slice's own time, not at its neighbour's.
        raw_runs = [_raw_write(tmp / "raw0.bin", frames, SLICE_MB)]
        rec_runs: list[dict] = []
        for k in range(PAIRS):
            rec_runs.append(_record(tmp / f"rec{k}.h5", frames, SLICE_MB))
            raw_runs.append(_raw_write(tmp / f"raw{k + 1}.bin", frames, SLICE_MB))
        ratios = [
            r["mb_per_s"] / ((raw_runs[k] + raw_runs[k + 1]) / 2) for k, r in enumerate(rec_runs)
        ]
        ratio = statistics.median(ratios)
        quartiles = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else [ratio] * 3
        repeats = [statistics.median(ratios[0::2]), statistics.median(ratios[1::2] or ratios)]
        out: dict = {
            "ratio": ratio,
            "ratio_repeats": [round(r, 3) for r in repeats],
            "ratio_repeat_spread": abs(repeats[0] - repeats[1]) / ratio,
            "ratio_spread": (max(ratios) - min(ratios)) / ratio,
            "ratio_iqr": (quartiles[2] - quartiles[0]) / ratio,
            "ratio_runs": ", ".join(f"{v:.3f}" for v in ratios),
            "mb_per_s": statistics.median(r["mb_per_s"] for r in rec_runs),
            "raw_write_mb_per_s": statistics.median(raw_runs),
            "raw_write_mb_per_s_runs": ", ".join(f"{v:.0f}" for v in raw_runs),
            "recorder_mb_per_s_runs": ", ".join(f"{r['mb_per_s']:.0f}" for r in rec_runs),
            "cpu_ms_per_frame": statistics.median(r["cpu_ms_per_frame"] for r in rec_runs),
            "slice_mb": SLICE_MB,
            "warmup_mb": WARMUP_MB,
            "warmup_mb_per_s": warmup,
            "dir": str(tmp.parent),
        }
        error = next((r["error"] for r in rec_runs if r["error"]), None)
        if error:
            out["error"] = error
        return out
    finally:
        shutil.rmtree(tmp, ignore_errors=True)


if __name__ == "__main__":
    import json

    print(json.dumps(run(10.0), indent=2))
