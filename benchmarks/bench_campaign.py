"""Campaign throughput: the same sessions re-analysed serially in this process and on
a LocalCluster of 2 worker processes, as ``snrmon campaign`` runs them.

Sessions: ``N_FLIGHTS`` short simulated flights recorded with the HIL rig (LWIR, two stops,
4x real time), each copied ``COPIES`` times (distinct files, the same content), in a temporary
folder (``$SNRMON_BENCH_DIR`` or the system's). Each executor runs the campaign with the fast
replay (the default) and with full frames. Figures: frames per second and sessions per minute
over the campaign's own time (the cluster's start-up, a one-off of a few seconds, is reported
apart as ``cluster_start_s``), and the 2-worker speed-up over serial. The files are read from the
page cache (they were just written): this measures the analysis, not the disk.
"""

from __future__ import annotations

import os
import shutil
import tempfile
import time
from dataclasses import replace
from pathlib import Path

KEY = "campaign"
EXTRA = "campaign"  # Dask and pyarrow
N_FLIGHTS = 2
COPIES = 3


def _record(folder: Path) -> list[str]:
    from snrmon.rig.rig import HilOptions, HilRig

    paths = []
    for seed in range(N_FLIGHTS):
        first = folder / f"flight{seed}-0.h5"
        opts = HilOptions(
            seed=seed,
            speed=4.0,
            stops_m=(37.0, 126.0),
            cameras=("lwir",),
            hover_s=4.0,
            out=str(first),
        )
        with HilRig(opts) as rig:
            rig.run()
        paths.append(str(first))
        for k in range(1, COPIES):
            copy = folder / f"flight{seed}-{k}.h5"
            shutil.copyfile(first, copy)
            paths.append(str(copy))
    return paths


def _warm(session: str) -> None:
    """The first task of a process pays the imports and the model's first curves (~4 s here):
    a one-off per worker, taken out of the figures and reported as ``worker_warmup_s``."""
    from snrmon.campaign.settings import AnalysisSettings
    from snrmon.campaign.tasks import analyse_camera

    analyse_camera(session, "lwir", AnalysisSettings())


def measure(sessions: list[str], workers: int = 2) -> dict[str, float]:
    """Serial vs ``workers`` processes on ``sessions``, fast and full-frame replay."""
    from distributed import Client

    from snrmon.campaign.run import local_cluster, run_dask, run_serial
    from snrmon.campaign.settings import AnalysisSettings

    out: dict[str, float] = {
        "sessions": float(len(sessions)),
        "load_avg_1min_before": os.getloadavg()[0],
    }

    def figures(name: str, result) -> None:
        if result.failures:
            raise RuntimeError(f"campaign bench: {result.failures[0]}")
        out[f"{name}_frames_per_s"] = result.frames_measured / result.seconds
        out[f"{name}_sessions_per_min"] = 60.0 * len(sessions) / result.seconds
        out[f"{name}_s"] = result.seconds

    t0 = time.perf_counter()
    with (
        local_cluster(workers) as cluster,
        Client(cluster) as client,
    ):
        client.wait_for_workers(workers)
        out["cluster_start_s"] = time.perf_counter() - t0
        t0 = time.perf_counter()
        client.run(_warm, sessions[0])
        out["worker_warmup_s"] = time.perf_counter() - t0
        _warm(sessions[0])
        for mode, fast in (("fast", True), ("full", False)):
            settings = replace(AnalysisSettings(), fast=fast)
            figures(f"serial_{mode}", run_serial(sessions, settings))
            on_cluster = run_dask(sessions, settings, scheduler=cluster.scheduler_address)
            figures(f"workers{workers}_{mode}", on_cluster)
            out[f"speedup_{mode}"] = out[f"serial_{mode}_s"] / out[f"workers{workers}_{mode}_s"]
    return out


def run(duration_s: float) -> dict[str, float]:
    base = os.environ.get("SNRMON_BENCH_DIR")
    with tempfile.TemporaryDirectory(prefix="snrmon-campaign-", dir=base) as tmp:
        sessions = _record(Path(tmp))
        return measure(sessions)
