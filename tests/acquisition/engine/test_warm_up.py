"""A live camera's compiled kernels are loaded before its first frame (acquisition/engine/
warm_up.py): the first real frame, calibrated or not, finds every kernel it calls ready (numba
adds a signature to a kernel when it loads or compiles one), and the live engine's own state is
not touched by the warm-up."""

from __future__ import annotations

import importlib
import json
import subprocess
import sys

import numpy as np
import pytest
from numba.core.registry import CPUDispatcher

from snrmon.acquisition.calibrate.calibration import BlackbodyCapture, calibrate_sensor
from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.inputs import SetRoi
from snrmon.acquisition.engine.warm_up import warm_up
from snrmon.acquisition.streams.ring import RingFrame
from tests.acquisition.calibration_scene import camera

KERNEL_MODULES = (
    "snrmon.acquisition.measure.jit",
    "snrmon.acquisition.measure.blob_kernel",
    "snrmon.acquisition.measure.rim_kernel",
    "snrmon.acquisition.measure.track_noise",
    "snrmon.acquisition.calibrate.kernels",
)


def _signatures() -> dict[str, int]:
    out = {}
    for name in KERNEL_MODULES:
        mod = importlib.import_module(name)
        for attr, value in vars(mod).items():
            if isinstance(value, CPUDispatcher):
                out[f"{name}.{attr}"] = len(value.signatures)
    return out


def _frames(shape, n: int, seed: int, resolved: bool) -> list[np.ndarray]:
    """A drone drifting on a noisy sky, as a camera gives it (uint16): a spot, or a drone
    25 x 13 px (the 37 m stop: measured against its extent's rim)."""
    rng = np.random.default_rng(seed)
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w]
    hw, hh = (12, 6) if resolved else (0, 0)
    out = []
    for i in range(n):
        x, y = w / 2 + 0.3 * i, h / 2 - 0.2 * i
        d2 = np.maximum(np.abs(xx - x) - hw, 0) ** 2 + np.maximum(np.abs(yy - y) - hh, 0) ** 2
        spot = 300.0 * np.exp(-d2 / (2 * 0.9**2))
        out.append(np.rint(2000.0 + spot + rng.normal(0, 6.0, shape)).astype(np.uint16))
    return out


def _first_frames_load(calibrated: bool, warm: bool, resolved: bool) -> dict[str, int]:
    """The kernel signatures the first real frames added (in this process): frames as a camera
    gives them, then read-only, as ``replay --fast`` hands them over (views into the file's
    memory map, which numba types apart from writable arrays)."""
    cam = camera("mwir", shape=(96, 128), seed=3)
    engine = CameraEngine("mwir", cam.shape)
    if calibrated:
        caps = [
            BlackbodyCapture(t, cam.blackbody(t, 8, seed=i)) for i, t in enumerate((283.0, 318.0))
        ]
        engine.set_calibration(calibrate_sensor(caps, cam.sensor))
    if warm:
        warm_up(engine)
        # the live engine untouched
        assert engine.roi_centre is None and engine.measurer.tracker is None
    before = _signatures()
    engine.post(SetRoi(64, 48))
    frames = _frames(cam.shape, 8, seed=8, resolved=resolved)
    for f in frames[4:]:
        f.flags.writeable = False
    for i, f in enumerate(frames):
        assert engine.process(RingFrame(f, i, i, i, None, engine.name)).measurement is not None
    after = _signatures()
    return {k: after[k] - before[k] for k in after if after[k] != before[k]}


@pytest.mark.slow
@pytest.mark.parametrize(("calibrated", "resolved"), [(False, False), (True, True)])
def test_the_first_real_frame_loads_no_kernel(calibrated, resolved):
    # Each case in a fresh interpreter: kernels loaded by other tests would hide a cold start.
    def first_frames_load(warm: bool) -> dict[str, int]:
        code = (
            "import json; "
            "from tests.acquisition.engine.test_warm_up import _first_frames_load as f; "
            f"print(json.dumps(f({calibrated}, {warm}, {resolved})))"
        )
        run = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, check=True
        )
        return json.loads(run.stdout.strip().splitlines()[-1])

    cold = first_frames_load(False)
    assert (
        "snrmon.acquisition.measure.blob_kernel.analyse_auto" in cold
    )  # a cold engine loads them...
    assert first_frames_load(True) == {}  # ... a warmed-up one finds them loaded
