"""Running a campaign: one task per (session, camera) on Dask distributed, or serially.

The client plans nothing it cannot see: each session's cameras are listed by a small task on a
worker (which also fails cleanly on a missing or corrupt file), then one task per camera is
submitted. Workers open the files by path (shared filesystem); only rows come back. A failed
task is recorded by session (and camera) with its error; the others complete. ``workers = 0``
runs the same tasks one after the other in this process, without Dask (the serial reference of
``snrmon bench``).

Default: a ``LocalCluster`` of ``workers`` single-threaded processes (h5py holds a lock per
process, so threads would serialise on the file reads); ``scheduler`` submits to an existing
cluster (``tcp://host:8786``), whose workers must see the session files at the same paths.
"""

from __future__ import annotations

import logging
import os
import time
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

from snrmon.campaign.settings import AnalysisSettings
from snrmon.campaign.tasks import TaskResult, analyse_camera, session_cameras


@dataclass
class CampaignResult:
    tasks: list[TaskResult]
    failures: list[dict]  # {"session", "camera" (None: the whole session), "error"}
    seconds: float
    executor: str  # "serial", "LocalCluster(2)" or the scheduler's address
    labels: dict[str, str] = field(default_factory=dict)  # session path -> name in the tables

    @property
    def frames_measured(self) -> int:
        return sum(t.n_frames for t in self.tasks)


def session_labels(paths: Sequence[str]) -> dict[str, str]:
    """Each session's name in the tables: its file stem, or (when two stems are equal) its
    path relative to the folder the sessions share."""
    stems = [Path(p).stem for p in paths]
    if len(set(stems)) == len(stems):
        return dict(zip(paths, stems, strict=True))
    absolute = [os.path.abspath(p) for p in paths]
    common = os.path.commonpath([os.path.dirname(a) for a in absolute])
    return {
        p: str(Path(os.path.relpath(a, common)).with_suffix(""))
        for p, a in zip(paths, absolute, strict=True)
    }


def _error(exc: BaseException) -> str:
    text = str(exc).strip() or type(exc).__name__
    return (
        text.splitlines()[0]
        if isinstance(exc, OSError | ValueError | KeyError)
        else (f"{type(exc).__name__}: {text.splitlines()[0]}")
    )


def run_serial(
    sessions: Sequence[str],
    settings: AnalysisSettings,
    *,
    frames: bool = False,
    progress: Callable[[int, int], None] | None = None,
) -> CampaignResult:
    """The campaign's tasks one after the other in this process (no Dask)."""
    labels = session_labels(sessions)
    t0 = time.perf_counter()
    tasks, failures = [], []
    done, total = 0, len(sessions)
    for path in sessions:
        try:
            cameras = session_cameras(os.path.abspath(path))
        except Exception as exc:  # any error fails this session's task only, and is listed
            failures.append({"session": path, "camera": None, "error": _error(exc)})
            cameras = []
        total += len(cameras)
        done += 1
        for cam in cameras:
            try:
                tasks.append(
                    analyse_camera(
                        os.path.abspath(path), cam, settings, frames=frames, label=labels[path]
                    )
                )
            except Exception as exc:  # this camera's task only
                failures.append({"session": path, "camera": cam, "error": _error(exc)})
            done += 1
            if progress:
                progress(done, total)
    return CampaignResult(tasks, failures, time.perf_counter() - t0, "serial", labels)


def local_cluster(workers: int):
    """A LocalCluster of ``workers`` single-threaded processes for the campaign's tasks.

    Dask sets ``MALLOC_TRIM_THRESHOLD_`` in its workers to return memory to the system; a fixed
    threshold also switches off glibc's adaptive mmap threshold, so every frame read (0.3-1.8
    MB) is mapped, faulted in and unmapped again: a full-frame replay took 3.7 s of CPU for
    three sessions in a worker with it, 2.3 s without. It is unset here. The workers' own log
    of a failed task is silenced: the failure is reported once, by session and camera.
    """
    import dask
    from distributed import LocalCluster

    with dask.config.set({"distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None}):
        return LocalCluster(
            n_workers=workers,
            threads_per_worker=1,
            processes=True,
            dashboard_address=None,
            silence_logs=logging.CRITICAL,
        )


def run_dask(
    sessions: Sequence[str],
    settings: AnalysisSettings,
    *,
    frames: bool = False,
    scheduler: str | None = None,
    workers: int = 2,
    progress: Callable[[int, int], None] | None = None,
    timeout_s: float = 30.0,
) -> CampaignResult:
    """The campaign on a LocalCluster of ``workers`` processes, or on ``scheduler``."""
    from distributed import Client, as_completed

    labels = session_labels(sessions)
    cluster = None
    if scheduler:
        try:
            client = Client(scheduler, timeout=timeout_s)
        except OSError as exc:
            raise OSError(f"cannot reach the Dask scheduler at {scheduler}: {exc}") from None
        executor = scheduler
    else:
        cluster = local_cluster(workers)
        client = Client(cluster)
        executor = f"LocalCluster({workers})"
    t0 = time.perf_counter()
    tasks, failures = [], []
    run = uuid.uuid4().hex[:8]
    try:
        meta, planning = {}, []
        for i, path in enumerate(sessions):
            fut = client.submit(
                session_cameras,
                os.path.abspath(path),
                pure=False,
                key=f"cameras-{i}-{Path(path).name}-{run}",
            )
            meta[fut.key] = (path, None)
            planning.append(fut)
        queue = as_completed(planning)
        total = len(meta)
        for done, fut in enumerate(queue, start=1):
            path, cam = meta[fut.key]
            try:
                value = fut.result()
            except Exception as exc:  # the task's own error, raised again here: that task only
                failures.append({"session": path, "camera": cam, "error": _error(exc)})
                value = None
            if cam is None and value is not None:
                for c in value:
                    f2 = client.submit(
                        analyse_camera,
                        os.path.abspath(path),
                        c,
                        settings,
                        frames=frames,
                        label=labels[path],
                        pure=False,
                        key=f"replay-{fut.key}-{c}",
                    )
                    meta[f2.key] = (path, c)
                    queue.add(f2)
                    total += 1
            elif value is not None:
                tasks.append(value)
            if progress:
                progress(done, total)
            fut.release()
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
    return CampaignResult(tasks, failures, time.perf_counter() - t0, executor, labels)
