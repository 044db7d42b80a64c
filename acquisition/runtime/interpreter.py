"""The process-wide settings a live session runs under, set when it starts and put back when it
stops: they belong to the interpreter, not to one session object.

- The interpreter's switch interval is :data:`SWITCH_INTERVAL_S`: a thread that wants the GIL
  (a camera's, the console's) waits at most that long for a thread running Python to hand it over,
  not the default 5 ms.
- The BLAS library (OpenBLAS with NumPy's wheels) runs on one thread. Its products in the live
  path are small; split over the cores, each call woke a BLAS worker that then spun for its
  next job: 4 % of a core, all the time, on a 2-core machine whose cores the cameras, the
  recorder and the console already share (measured with ``perf`` under ``snrmon bench --only
  gui``: ``blas_thread_server`` in a thread of its own, ``exec_blas`` called from the
  measuring threads).
"""

from __future__ import annotations

import sys

from threadpoolctl import threadpool_limits

SWITCH_INTERVAL_S = 0.001


class LiveInterpreter:
    """:meth:`apply` the live settings once (more calls do nothing), :meth:`restore` what was
    there before."""

    def __init__(self) -> None:
        self._switch_interval: float | None = None  # the interpreter's, while applied
        self._blas: threadpool_limits | None = None

    @property
    def applied(self) -> bool:
        return self._blas is not None

    def apply(self) -> None:
        if self.applied:
            return
        if sys.getswitchinterval() > SWITCH_INTERVAL_S:
            self._switch_interval = sys.getswitchinterval()
            sys.setswitchinterval(SWITCH_INTERVAL_S)
        self._blas = threadpool_limits(limits=1, user_api="blas")

    def restore(self) -> None:
        if self._switch_interval is not None:
            sys.setswitchinterval(self._switch_interval)
            self._switch_interval = None
        if self._blas is not None:
            self._blas.restore_original_limits()
            self._blas = None
