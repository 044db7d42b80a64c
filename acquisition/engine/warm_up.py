"""The compiled kernels loaded before a live camera's first frame, not during it.

The per-frame analysis is compiled with numba (``acquisition.measure.jit``); each kernel's machine
code is loaded from numba's cache the first time it is called in a process (about 0.2 s for
them all; on a machine that has never run snrmon it is compiled: 15-22 s). A live engine paid
that inside its first measured frames, which then waited in the frame ring: the acquisition
benchmark's latency p99 was 150-160 ms over 20 s, all of it from the first second.
:func:`warm_up` runs the whole per-frame path (click, tracking, Eq. 4, the lazy correction with
the engine's calibration, the sky temperature, the section 6 noise; an unresolved and a resolved
drone; frames as a camera gives them and as ``replay --fast`` reads them from a file) on
synthetic frames in a throwaway engine of the same settings, so the live engine's state is not
touched. (A first run on a new machine, before this covered the resolved drone,
compiled its kernels at the 37 m stop and dropped 89 MWIR frames in make demo.)
"""

from __future__ import annotations

import time

import numpy as np

from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.inputs import SetRoi
from snrmon.acquisition.streams.ring import RingFrame

WARM_UP_FRAMES = 3  # the click's frame, then frames that follow the track


def warm_up(engine: CameraEngine) -> float:
    """Measure a few synthetic frames (a drone on a noisy sky, unresolved then resolved, the
    engine's frame shape, uint16 as a camera gives them) with a copy of ``engine``'s settings;
    returns the seconds it took."""
    t0 = time.perf_counter()
    m = engine.measurer
    twin = CameraEngine(
        engine.name,
        engine.shape,
        engine.config,
        window=m.meter.running.window,
        track=m.track,
        tracker_config=m.tracker_config,
    )
    if engine.corrector.calibration is not None:
        twin.set_calibration(engine.corrector.calibration)
    h, w = engine.shape
    rng = np.random.default_rng(0)  # the frames' content does not matter, only the paths taken
    y0, x0 = h // 2, w // 2
    # An unresolved drone (the 7x7 rim), then a resolved one wider than the box's guard (its
    # extent's rim, read through other views of the frame): each path's kernels.
    for half_w, half_h in ((0, 0), (12, 6)):
        sky = rng.normal(1000.0, 5.0, (h, w))
        yy, xx = np.mgrid[y0 - 20 : y0 + 21, x0 - 20 : x0 + 21]
        dx = np.maximum(np.abs(xx - x0) - half_w, 0)
        dy = np.maximum(np.abs(yy - y0) - half_h, 0)
        sky[y0 - 20 : y0 + 21, x0 - 20 : x0 + 21] += 200.0 * np.exp(-(dx**2 + dy**2) / 1.28)
        frame = np.clip(np.rint(sky), 0, 65535).astype(np.uint16)
        # As a camera gives it (writable), then as ``replay --fast`` does: a read-only view
        # into the file's memory map, which numba compiles apart from a writable array (the
        # first fast replay after an install or a change of the kernels compiled it: ~1 s).
        read_only = frame.view()
        read_only.flags.writeable = False
        for pixels in (frame, read_only):
            twin.post(SetRoi(x0, y0))
            for i in range(WARM_UP_FRAMES):
                twin.process(RingFrame(pixels, i, i, i, None, twin.name))
    return time.perf_counter() - t0
