"""Heavy work away from the measurement threads: one worker process, shared by the process.

The model's recomputation (a new sky temperature, a PSF measured from the flight: ~0.3-0.5 s a
camera) and the PSF fit after an unresolved stop (``acquisition.calibrate.psf_estimate``: about
a second) are NumPy and Python that hold the interpreter lock nearly all the time. Run in a thread
of the console they take the lock from the cameras' measurement threads for a switch interval at
a time, and a frame waits (``docs/engine.md``, "Where a live frame's time goes"). Here they run
in a worker process instead, spawned on first use (or by :func:`start`, ahead of the flight):
the console process only pickles the inputs and the (small) results. The worker runs at a lower
scheduling priority (``NICE``): on a machine with a core to spare it takes that core, on a busy
one it waits for the cameras and the measurement, whose frames cannot wait.

:func:`submit` returns a :class:`concurrent.futures.Future`; its callbacks run on the pool's
own thread in this process. The functions must be importable by name (module level), their
arguments and results picklable. A worker that dies (killed, out of memory) fails the futures
it held with ``BrokenProcessPool`` and the next :func:`submit` starts a new one.
"""

from __future__ import annotations

import atexit
import multiprocessing as mp
import os
import threading
from collections.abc import Callable
from concurrent.futures import Future, ProcessPoolExecutor
from concurrent.futures.process import BrokenProcessPool
from typing import Any

from snrmon.drivers.lifetime import die_with_parent

NICE = 10
"""How much lower the worker's scheduling priority is than the console's (``os.nice``)."""

_lock = threading.Lock()
_pool: ProcessPoolExecutor | None = None
_closing = threading.Event()  # set at exit: no new job is begun


def _lower_priority(parent_pid: int) -> None:
    """The worker's initializer: background work yields the CPU to the live path, and the
    worker ends with the console however it ends (a parent-death signal)."""
    die_with_parent(parent_pid)
    if hasattr(os, "nice"):
        os.nice(NICE)


def _warm() -> None:
    """Imports the model in the worker, so that the first real job does not pay for it."""
    import snrmon.model.snr  # noqa: F401


def _executor() -> ProcessPoolExecutor:
    global _pool
    with _lock:
        if _pool is None:
            _pool = ProcessPoolExecutor(
                max_workers=1,
                mp_context=mp.get_context("spawn"),
                initializer=_lower_priority,
                initargs=(os.getpid(),),
            )
            _pool.submit(_warm)
        return _pool


def start() -> None:
    """Spawn the worker now (its imports take a second of CPU): before a flight's clock."""
    _executor()


def submit(fn: Callable[..., Any], *args: Any, **kwargs: Any) -> Future:
    """``fn(*args, **kwargs)`` in the worker process. Once the pool is closing (the exit: the
    interpreter's own hook closes it before :mod:`atexit` runs) the job is not begun: its future
    comes back cancelled, as the jobs the closing pool drops, so that a callback of a job that
    finished during the exit (a PSF fit adopting its estimate, which asks for a recomputation)
    ends quietly instead of failing on a pool that takes no more work. Callbacks check
    ``job.cancelled()``."""
    global _pool
    if _closing.is_set():
        return _dropped()
    pool = _executor()
    try:
        return pool.submit(fn, *args, **kwargs)
    except BrokenProcessPool:  # the worker died: a new one for this and later jobs
        with _lock:
            if _pool is pool:
                _pool = None
        return _executor().submit(fn, *args, **kwargs)
    except RuntimeError:  # "cannot schedule new futures after (interpreter) shutdown"
        _closing.set()
        return _dropped()


def _dropped() -> Future:
    job: Future = Future()
    job.cancel()
    return job


@atexit.register
def _shutdown() -> None:
    """At exit, jobs not begun are dropped (a recomputation nobody will read)."""
    _closing.set()
    with _lock:
        pool = _pool
    if pool is not None:
        pool.shutdown(wait=True, cancel_futures=True)
