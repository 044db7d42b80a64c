"""The GUI thread's CPU time per camera frame: a camera view shows and paints one 1280x720
frame (offscreen), as the console's frame timer does 60 times a second for the MWIR.

The frame is made ready by the display's feed as in the console (off the GUI thread's clock:
only the view's part is timed), then shown (:meth:`CameraView.show_frame`) and painted (the
event loop's paint of the image's region). The thread's CPU time, not the wall clock: on a
machine shared with other jobs the wall clock measures the machine, the CPU time the work (less
exactly: a loaded machine's caches are colder). Batches of :data:`FRAMES` frames, the first two
left out (caches, the first reduction); the minimum and the median of the others, at the views'
sizes of a 1366x768 and of a 1920x1080 screen.
"""

from __future__ import annotations

import os
import time

KEY = "camera_view"
EXTRA = "gui"  # the console (PySide6, pyqtgraph)
VIEWS = {"1366x768": (400, 300), "1920x1080": (640, 420)}
SHAPE = (720, 1280)
FRAMES = 50
BATCHES = 12


class _Camera:
    """Four noisy 1280x720 frames in turn, the newest always new."""

    name = "mwir"
    shape = SHAPE

    def __init__(self) -> None:
        import numpy as np

        rng = np.random.default_rng(1)
        self.bank = [rng.integers(900, 1100, SHAPE, dtype=np.uint16) for _ in range(4)]
        self.k = 0

    def latest_frame(self, *, unless_seq=None, out=None):
        import numpy as np

        from snrmon.acquisition.streams.ring import RingFrame

        self.k += 1
        pixels = self.bank[self.k % 4]
        if out is not None:
            np.copyto(out, pixels)
            pixels = out
        return RingFrame(pixels, self.k, self.k, time.monotonic_ns(), None, self.name)


def _view_cpu_ms(app, size: tuple[int, int]) -> list[float]:
    """GUI-thread CPU (ms) per frame of each batch, a view of ``size`` (width, height)."""
    from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
    from snrmon.gui.camera_view import CameraView
    from snrmon.gui.frame_feed import FrameFeed

    view = CameraView("mwir", SHAPE, PeakSnrConfig())
    view.resize(*size)
    view.show()
    app.processEvents()
    view.show_gps((640.0, 360.0))  # the GPS ring over the image, as in the field
    feed = FrameFeed(_Camera())
    out = []
    for _ in range(BATCHES):
        cpu = 0.0
        for _ in range(FRAMES):
            feed.prepare()
            shown = feed.newest()
            t = time.thread_time()
            view.show_frame(shown)
            feed.request = view.display_request()
            app.processEvents()
            cpu += time.thread_time() - t
        out.append(1e3 * cpu / FRAMES)
    view.close()
    return out


def run(duration_s: float) -> dict:
    os.environ.setdefault("QT_QPA_PLATFORM", "offscreen")
    import numpy as np

    from snrmon.gui.app import console_application

    app = console_application(headless=True)
    figures: dict = {"load_at_start": os.getloadavg()[0] if hasattr(os, "getloadavg") else None}
    for screen, size in VIEWS.items():
        batches = np.array(_view_cpu_ms(app, size)[2:])
        figures[f"{screen}_gui_cpu_ms_per_frame_min"] = round(float(batches.min()), 3)
        figures[f"{screen}_gui_cpu_ms_per_frame_median"] = round(float(np.median(batches)), 3)
    return figures
