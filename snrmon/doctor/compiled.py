"""The compiled per-frame analysis loads (numba, ``acquisition.measure.jit``).

The first run of snrmon on a machine compiles the analysis (15-22 s on the development
machine) and keeps the machine code in numba's cache; every later process loads it (~0.2 s).
The doctor runs it once, so the first flight does not start by compiling, and a machine where
it cannot compile or load (numba or llvmlite broken by another package's upgrade) is found
before the drone flies, not at the first click.
"""

from __future__ import annotations

import time

from snrmon.doctor import FAIL, PASS, Check


def check_compiled_analysis(shape: tuple[int, int] = (720, 1280)) -> Check:
    """Run the per-frame path once on synthetic frames
    (:func:`snrmon.acquisition.engine.warm_up`)."""
    t0 = time.perf_counter()
    try:
        from snrmon.acquisition.engine.camera_engine import CameraEngine
        from snrmon.acquisition.engine.warm_up import warm_up

        warm_up(CameraEngine("doctor", shape))
    except Exception as exc:  # an import or compile failure of numba/llvmlite, whatever it is
        return Check(
            "compiled-analysis",
            FAIL,
            f"the per-frame analysis does not compile: {exc}",
            "reinstall snrmon in a fresh venv with its tested versions "
            "(pip install -c constraints.txt snrmon): numba and llvmlite must match NumPy",
        )
    seconds = time.perf_counter() - t0
    return Check(
        "compiled-analysis",
        PASS,
        f"the per-frame analysis compiled or loaded in {seconds:.1f} s (a first run on a "
        "machine compiles it once)",
        data={"seconds": seconds},
    )
