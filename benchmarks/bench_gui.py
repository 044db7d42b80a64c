"""The console under full load, offscreen: frames shown per second per camera, event-loop latency
(p50/p99 lateness of a 10 ms timer, the delay any UI action would wait), and frames dropped.

``<camera>_shown_fps`` counts the distinct frames handed to the view; ``<camera>_painted_fps``
the distinct frames its image item actually painted (two frames handed over between two paints
count as one painted); ``<camera>_delivered_fps`` the frames the camera delivered to the console
over the same time, as its status bar counts them (gui/frame_feed.py): the console draws every
frame when shown = painted = delivered.

Both simulated cameras at their full rates (MWIR 1280x720 at 60 fps, LWIR 640x480 at 30 fps)
through the real shared-memory ring and ShmCamera, measurement on (ROI on the spot) and
recording on (HDF5 into a temporary directory), with the console's own timers drawing.
"""

from __future__ import annotations

import os
import tempfile
import time
import uuid
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

KEY = "gui"
EXTRA = "gui"  # the console (PySide6, pyqtgraph)

CAMERAS = {"mwir": (1280, 720, 60.0), "lwir": (640, 480, 30.0)}


class SpotBank:
    """Picklable render: cycles through 16 precomputed noisy frames with a spot at the centre,
    so that rendering costs a copy and the benchmark measures the console, not the simulator."""

    def __init__(self, width: int, height: int, seed: int = 3) -> None:
        self.width, self.height, self.seed = width, height, seed
        self._bank: np.ndarray | None = None

    def __call__(self, counter: int) -> np.ndarray:
        if self._bank is None:
            rng = np.random.default_rng(self.seed)
            yy, xx = np.mgrid[0 : self.height, 0 : self.width]
            cx, cy = self.width // 2, self.height // 2
            spot = 300.0 * np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * 0.8**2))
            bank = 1000.0 + spot + rng.normal(0.0, 8.0, (16, self.height, self.width))
            self._bank = np.clip(np.rint(bank), 0, 65535).astype(np.uint16)
        return self._bank[counter % 16]

    def __getstate__(self) -> dict:
        return {"width": self.width, "height": self.height, "seed": self.seed, "_bank": None}


def run(duration_s: float) -> dict:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    from snrmon.gui.app import console_application
    from snrmon.sim.devices.shm_camera import ShmProducer

    console_application(headless=True)
    tag = uuid.uuid4().hex[:8]
    rings = {cam: f"snrmon-benchgui-{cam}-{tag}" for cam in CAMERAS}
    producers = [
        ShmProducer(rings[c], w, h, SpotBank(w, h), fps=fps, slots=16)
        for c, (w, h, fps) in CAMERAS.items()
    ]
    with tempfile.TemporaryDirectory() as tmp:
        for p in producers:
            p.start()
        session = _session_on(rings)
        session.start()
        window = None
        try:
            window = _console_window(session, Path(tmp))
            sample = _sample_under_load(window, session, Path(tmp), duration_s)
        finally:
            if window is not None:
                window.close()
            session.stop()
            for p in producers:
                p.close()
    return _gui_figures(window, sample)


def _session_on(rings: dict[str, str]):
    """A session of both cameras, each on its shared-memory ring."""
    from snrmon.acquisition.config import session_config_from_dict
    from snrmon.acquisition.runtime.session import Session
    from snrmon.drivers.camera.shm import ShmCamera

    table = {
        c: {"source": "shm", "address": rings[c], "width_px": w, "height_px": h}
        for c, (w, h, _) in CAMERAS.items()
    }
    config = session_config_from_dict({"cameras": table})
    devices = {c: ShmCamera(c, rings[c]) for c in CAMERAS}
    shapes = {c: (h, w) for c, (w, h, _) in CAMERAS.items()}
    return Session(config, cameras=devices, shapes=shapes)


def _console_window(session, tmp: Path):
    """The console shown on ``session`` (its settings in ``tmp``), an ROI on each camera's
    spot, recording into ``tmp``."""
    from PySide6.QtCore import QSettings

    from snrmon.gui.main_window import ConsoleWindow

    settings = QSettings(str(tmp / "bench.ini"), QSettings.Format.IniFormat)
    window = ConsoleWindow(session, settings=settings)
    window.set_size(1600, 1000)
    window.show()
    for c, (w, h, _) in CAMERAS.items():
        session.set_roi(c, w // 2, h // 2)
    session.start_recording(tmp / "bench.h5")
    return window


@dataclass
class _Sample:
    """The console's counters at the start and the end of the measured time, its length and
    the event loop's lateness of each 10 ms tick."""

    shown0: dict[str, int]
    delivered0: dict[str, int]
    painted0: dict[str, int]
    before: dict
    after: dict = field(default_factory=dict)
    late_ms: list[float] = field(default_factory=list)
    elapsed_s: float = 0.0


def _sample_under_load(window, session, tmp: Path, duration_s: float) -> _Sample:
    """After a second's warm-up, ``duration_s`` of the console at full load, a precise 10 ms
    timer probing the event loop; the recording is stopped at the end."""
    from PySide6.QtCore import QEventLoop, Qt, QTimer

    loop = QEventLoop()
    QTimer.singleShot(1000, loop.quit)  # warm-up: rings attached, first frames drawn
    loop.exec()
    sample = _Sample(
        shown0={c: p.view.frames_shown for c, p in window.panels.items()},
        delivered0={c: f.delivered for c, f in window.feeds.items()},
        painted0={c: p.view.image.frames_painted for c, p in window.panels.items()},
        before=session.status().cameras,
    )
    last = [time.perf_counter()]

    def tick() -> None:
        now = time.perf_counter()
        sample.late_ms.append((now - last[0]) * 1e3 - 10.0)
        last[0] = now

    probe = QTimer()
    probe.setTimerType(Qt.TimerType.PreciseTimer)
    probe.timeout.connect(tick)
    t0 = time.perf_counter()
    probe.start(10)
    QTimer.singleShot(round(duration_s * 1000), loop.quit)
    loop.exec()
    probe.stop()
    sample.elapsed_s = time.perf_counter() - t0
    sample.after = session.status().cameras
    session.stop_recording()
    return sample


def _gui_figures(window, sample: _Sample) -> dict:
    """Per camera the frames shown, painted, delivered and received per second and the frames
    dropped; the event loop's lateness (p50, p99, max)."""
    elapsed = sample.elapsed_s
    figures: dict = {"duration_s": round(elapsed, 2)}
    for c in CAMERAS:
        fa, fb = sample.after[c].frames, sample.before[c].frames
        figures[f"{c}_shown_fps"] = round(
            (window.panels[c].view.frames_shown - sample.shown0[c]) / elapsed, 1
        )
        figures[f"{c}_painted_fps"] = round(
            (window.panels[c].view.image.frames_painted - sample.painted0[c]) / elapsed, 1
        )
        figures[f"{c}_delivered_fps"] = round(
            (window.feeds[c].delivered - sample.delivered0[c]) / elapsed, 1
        )
        figures[f"{c}_camera_fps"] = round((fa.received - fb.received) / elapsed, 1)
        figures[f"{c}_dropped"] = fa.lost - fb.lost
    lat = np.array(sample.late_ms[1:] or [np.nan])
    figures["event_loop_late_ms_p50"] = round(float(np.percentile(lat, 50)), 2)
    figures["event_loop_late_ms_p99"] = round(float(np.percentile(lat, 99)), 2)
    figures["event_loop_late_ms_max"] = round(float(np.max(lat)), 2)
    return figures


if __name__ == "__main__":
    print(run(5.0))
