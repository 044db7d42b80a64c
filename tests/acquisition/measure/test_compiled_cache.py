"""Exactness of the per-frame shortcuts beside the compiled kernels, and the kernels' cache.

The tracker's object history keeps its values sorted instead of sorting them for every median;
numba's cache of a kernel must follow changes in the kernels it calls from other modules.
"""

from __future__ import annotations

import numpy as np


def test_object_history_medians_are_statistics_median():
    import statistics

    from snrmon.acquisition.measure.blob import Blob
    from snrmon.acquisition.track.candidate import ObjectHistory

    rng = np.random.default_rng(900)
    hist = ObjectHistory(frames=25, min_frames=5)
    for i in range(400):
        p = float(rng.choice([rng.uniform(0, 100), 7.5, 12.0]))  # ties too
        a = int(rng.integers(1, 9))
        blob = Blob(
            1,
            1,
            p,
            0.0,
            1.0,
            0.0,
            0.5,
            a,
            (0, 0, 2, 2),
            1.0,
            1.0,
            0.1,
            a,
            (0, 0, 2, 2),
            (0, 0, 9, 9),
        )
        hist.add(blob)
        enough = len(hist.prominences) >= 5
        assert hist.prominence == (statistics.median(hist.prominences) if enough else None)
        assert hist.area == (statistics.median(hist.areas) if enough else None)
        if i % 50 == 49:  # restored from a snapshot: the same medians on
            again = ObjectHistory(frames=25, min_frames=5)
            again.restore(hist.snapshot())
            assert (again.prominence, again.area) == (hist.prominence, hist.area)
            hist = again


def test_every_kernel_cache_is_judged_on_all_kernel_modules():
    """numba compiles a kernel's callees from other modules into its cache but judges the
    cache by the caller's file: jit._AllKernels makes a change in any kernel module
    recompile every kernel."""
    from snrmon.acquisition.calibrate import kernels as cal_kernels
    from snrmon.acquisition.measure import blob_kernel, jit, rim_kernel, track_noise

    checked = 0
    for module in (jit, blob_kernel, rim_kernel, track_noise, cal_kernels):
        for value in vars(module).values():
            func = getattr(value, "py_func", None)
            if func is not None and func.__module__ == module.__name__:
                assert isinstance(value._cache._impl.locator, jit._AllKernels), value
                checked += 1
    assert checked >= 20
