"""The console in a real window: frames painted against frames delivered per camera, and the
event loop's lateness, on a real X server (Xvfb, Qt's xcb platform) at 1366x768 and 1920x1080.

The offscreen benchmark (``bench_gui``) paints into memory that nobody shows: a real window also
has its backing store flushed to the X server, and the window fills a real screen, at a first
start the whole of it. Here each screen size gets its own Xvfb and its own process (a
QApplication binds to one display), and in it the console of ``snrmon demo``: the simulated
collection day (both cameras, MWIR 1280x720 at 60 frames/s and LWIR 640x480 at 30 frames/s,
rendered by their camera processes; the rangefinder and GPS on pseudo-terminals), the simulated
operator clicking the drone at the first stop, the window at its first-start size (no saved
settings: the whole screen), the console's own timers drawing.

Per screen size, over ``duration_s`` after a warm-up of :data:`WARM_UP_S`:

- ``<size>_<camera>_painted_fps``: distinct frames the camera's image item painted per second
  (what reached the window; two frames handed over between two paints count as one);
- ``<size>_<camera>_delivered_fps``: frames the camera delivered to the console's pipeline per
  second (its frame ring's pushes, as the session's frame accounting counts them);
- ``<size>_<camera>_header_fps``: the rate the camera's header showed at the end;
- ``<size>_event_loop_late_ms_p50/p99/max``: how late a 10 ms precise timer's ticks were (the
  wait any click or key would have);
- ``<size>_gui_thread_cpu_ms_per_s``: the GUI thread's CPU time per second (what the window
  costs, whatever the machine's load lets it have), ``<size>_process_cpu_cores`` the console
  process's (its threads, the simulated rangefinder's and GPS's included; the cameras are
  processes of their own);
- ``<size>_load_at_start``: the machine's 1-minute load average as the run began (other
  processes; the figures of a loaded machine are not those of a field laptop).

The simulated day is lossless (its clock waits for the console: ``snrmon/rig/flight_clock.py``),
so a console that cannot keep up shows as a delivered rate under the cameras' 60 and 30: the
goals compare painted with delivered, and the delivered rate is reported beside them.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path

KEY = "gui_window"
EXTRA = "gui"  # the console (PySide6, pyqtgraph)
CAMERAS = ("mwir", "lwir")
WARM_UP_S = 4.0  # after the first frames: the layout fitted, the drone clicked
PROBE_MS = 10
START_TIMEOUT_S = 180.0  # the rig's calibration and the analysis's first compilation


def _late_probe(late_ms: list[float]):
    """A :data:`PROBE_MS` precise timer recording how late each tick is (ms)."""
    from PySide6.QtCore import Qt, QTimer

    last = [time.perf_counter()]

    def tick() -> None:
        now = time.perf_counter()
        late_ms.append((now - last[0]) * 1e3 - PROBE_MS)
        last[0] = now

    probe = QTimer()
    probe.setTimerType(Qt.TimerType.PreciseTimer)
    probe.timeout.connect(tick)
    return probe, last


def _wait(seconds: float) -> None:
    """Run the event loop for ``seconds``."""
    from PySide6.QtCore import QEventLoop, QTimer

    loop = QEventLoop()
    QTimer.singleShot(round(seconds * 1000), loop.quit)
    loop.exec()


def _counts(window, session) -> dict:
    st = session.status().cameras
    return {
        c: (
            window.panels[c].view.image.frames_painted,
            st[c].frames.received,
            window.feeds[c].shown,
            window.feeds[c].delivered,
        )
        for c in CAMERAS
    }


def _operator(rig, done: threading.Event) -> None:
    """The demo's simulated operator: clicks the drone at the first stop (``HilRig.step``)."""
    while not done.is_set() and rig.step():
        done.wait(0.5)


def measure_window(duration_s: float) -> dict:
    """The figures of one console on ``$DISPLAY`` (this process's QApplication is on it)."""
    os.environ["QT_QPA_PLATFORM"] = "xcb"
    from PySide6.QtCore import QSettings

    from snrmon.gui.app import console_application
    from snrmon.gui.main_window import ConsoleWindow
    from snrmon.rig.rig import HilOptions, HilRig

    console_application()
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else None
    rig = HilRig(HilOptions(seed=0, transit_mps=12.0, adopt_psf=True))
    done = threading.Event()
    with tempfile.TemporaryDirectory(prefix="snrmon-bench-window-") as tmp, rig:
        operator = threading.Thread(target=_operator, args=(rig, done), daemon=True)
        operator.start()
        settings = QSettings(str(Path(tmp) / "first-start.ini"), QSettings.Format.IniFormat)
        window = ConsoleWindow(rig.session, curves=rig.predictor.curve, settings=settings)
        try:
            window.show()
            deadline = time.monotonic() + START_TIMEOUT_S
            while not all(p.view.image.frames_painted for p in window.panels.values()):
                if time.monotonic() > deadline:
                    raise RuntimeError("the console painted no frame within the start timeout")
                _wait(0.2)
            _wait(WARM_UP_S)
            late_ms: list[float] = []
            probe, last = _late_probe(late_ms)
            before = _counts(window, rig.session)
            cpu0 = (time.thread_time(), time.process_time())
            t0 = last[0] = time.perf_counter()
            probe.start(PROBE_MS)
            _wait(duration_s)
            probe.stop()
            elapsed = time.perf_counter() - t0
            cpu = (time.thread_time() - cpu0[0], time.process_time() - cpu0[1])
            after = _counts(window, rig.session)
            headers = {c: rig.session.status().cameras[c].fps for c in CAMERAS}
            size = (window.width(), window.height())
        finally:
            done.set()
            window.close()
            operator.join(5.0)
    figures = _figures(before, after, elapsed, late_ms[1:], headers, size, load)
    figures["gui_thread_cpu_ms_per_s"] = round(1e3 * cpu[0] / elapsed, 1)
    figures["process_cpu_cores"] = round(cpu[1] / elapsed, 2)
    return figures


def _figures(before, after, elapsed, late_ms, headers, size, load) -> dict:
    import numpy as np

    out: dict = {"duration_s": round(elapsed, 2), "window": list(size), "load_at_start": load}
    for c in CAMERAS:
        d = [a - b for a, b in zip(after[c], before[c], strict=True)]
        out[f"{c}_painted_fps"] = round(d[0] / elapsed, 2)
        out[f"{c}_delivered_fps"] = round(d[1] / elapsed, 2)
        out[f"{c}_feed_shown_fps"] = round(d[2] / elapsed, 2)
        out[f"{c}_feed_delivered_fps"] = round(d[3] / elapsed, 2)
        out[f"{c}_header_fps"] = round(headers[c], 2)
    lat = np.array(late_ms or [np.nan])
    out["event_loop_late_ms_p50"] = round(float(np.percentile(lat, 50)), 2)
    out["event_loop_late_ms_p99"] = round(float(np.percentile(lat, 99)), 2)
    out["event_loop_late_ms_max"] = round(float(np.max(lat)), 2)
    return out


def run(duration_s: float) -> dict:
    from snrmon.benchmarks.goals import WINDOW_SCREENS
    from snrmon.benchmarks.xvfb import start_xvfb

    figures: dict = {}
    for size in WINDOW_SCREENS:
        with start_xvfb(size) as xvfb, tempfile.TemporaryDirectory() as tmp:
            out = Path(tmp) / "figures.json"
            env = {
                **os.environ,
                "DISPLAY": xvfb.display,
                "QT_QPA_PLATFORM": "xcb",
                "XDG_CONFIG_HOME": str(Path(tmp) / "config"),
            }
            argv = [sys.executable, "-m", __name__, repr(duration_s), str(out)]
            proc = subprocess.run(argv, env=env, capture_output=True, text=True, check=False)
            if proc.returncode != 0 or not out.exists():
                sys.stderr.write(proc.stdout + proc.stderr)
                raise RuntimeError(f"the console at {size} failed (exited {proc.returncode})")
            for name, value in json.loads(out.read_text()).items():
                figures[f"{size}_{name}"] = value
    return figures


if __name__ == "__main__":
    Path(sys.argv[2]).write_text(json.dumps(measure_window(float(sys.argv[1]))))
