"""The QApplication and :func:`run_console`, the one entry the CLI uses to show the console.

``run_console`` does not start or stop the session: the caller owns its lifetime (``with
session: run_console(session, ...)``), so the same session can outlive a closed window.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from pathlib import Path

from PySide6.QtCore import QEventLoop, QSettings, QTimer, qInstallMessageHandler
from PySide6.QtGui import QPixmapCache
from PySide6.QtWidgets import QApplication

from snrmon.acquisition.runtime.session import Session
from snrmon.gui.main_window import ConsoleWindow
from snrmon.gui.range_plot import CurveSource
from snrmon.gui.theme import apply_dark_theme, configure_pyqtgraph

# The offscreen platform warns on every dock and window resize that it cannot pass size hints
# to a window manager it does not have: dozens of lines a minute that bury the stop table.
_OFFSCREEN_NOISE = ("This plugin does not support propagateSizeHints()",)


def _offscreen_messages(_mode, _context, message: str) -> None:
    """Qt's messages on stderr, less the offscreen platform's own noise."""
    if message not in _OFFSCREEN_NOISE:
        print(message, file=sys.stderr)


HEADLESS_SIZE = (1920, 1080)
"""The window's size offscreen, where there is no screen to fill (``--size`` changes it)."""

OFFSCREEN_FRAME_INTERVAL_MS = 250
# Qt's pixmap cache holds every item drawn as a cached pixmap (the plots' axes with their grids,
# each the size of its plot; the range plots' model curves): its default 10 MB is less than a
# 1920x1080 console's, so those were evicted and drawn afresh at each repaint (a range plot's
# repaint 26-30 ms of the GUI thread's CPU, its axes redrawn at every one of them; 7.9 ms and
# none with room). Room for this many screens' worth of 32-bit pixels:
PIXMAP_CACHE_SCREENS = 12
"""How often an offscreen (headless) console shows the newest frames: the screenshot at the end
still has the last ones; the status, table and status file refresh as on a screen."""


def console_application(*, headless: bool = False) -> QApplication:
    """The process's QApplication (created once; offscreen when ``headless``), dark-themed."""
    app = QApplication.instance()
    if app is None:
        if headless:
            os.environ["QT_QPA_PLATFORM"] = "offscreen"
        if os.environ.get("QT_QPA_PLATFORM") == "offscreen":
            qInstallMessageHandler(_offscreen_messages)
        app = QApplication(sys.argv[:1])
        app.setOrganizationName("snrmon")
        app.setApplicationName("console")
    configure_pyqtgraph()
    apply_dark_theme(app)
    QPixmapCache.setCacheLimit(pixmap_cache_kb(app))
    return app


def pixmap_cache_kb(app: QApplication) -> int:
    """The pixmap cache's size (kB) for the console on ``app``'s primary screen:
    :data:`PIXMAP_CACHE_SCREENS` of its 32-bit pixels, never under Qt's default."""
    screen = app.primaryScreen()
    size = screen.size() if screen is not None else None
    pixels = size.width() * size.height() if size is not None else 0
    return max(QPixmapCache.cacheLimit(), PIXMAP_CACHE_SCREENS * pixels * 4 // 1024)


def run_console(
    session: Session,
    *,
    curves: CurveSource | None = None,
    headless: bool = False,
    duration_s: float | None = None,
    screenshot: str | Path | None = None,
    settings: QSettings | None = None,
    status_file: str | Path | None = None,
    theme: str | None = None,
    font_scale: float | None = None,
    size: tuple[int, int] | None = None,
    until: threading.Event | None = None,
) -> int:
    """Show the console on a started ``session`` until the window closes; returns 0.

    Args:
        curves: ``curves(camera) -> {name: (ranges_m, snr)}`` (or ``(ranges_m, low, high)``
            for a band) from the model; None draws no model. Only used when the session has
            no predictor (the console asks the session for the model, it builds none).
        headless: run offscreen (no display needed); only effective before the first
            QApplication of the process exists.
        duration_s: close the window after this many seconds (None: until the operator quits).
        until: close the window once this event is set (by any thread: e.g. the simulated
            flight's completion); looked at on the GUI thread five times a second.
        screenshot: save the whole window to this PNG just before it closes.
        settings: QSettings to use (default: the user's snrmon/console settings).
        status_file: keep the console's state in this JSON file (:mod:`snrmon.gui.status_file`),
            rewritten with every status refresh.
        theme: "dark" or "daylight" (None: the saved choice).
        font_scale: the texts' size over normal, 0.8 to 2 (None: the saved one).
        size: (width, height) of the window in pixels, at the screen's top left (None: the
            saved geometry, or the whole available screen at a first start; offscreen
            :data:`HEADLESS_SIZE`).
    """
    if duration_s is not None and not duration_s > 0:
        raise ValueError(f"duration must be positive seconds, got {duration_s}")
    console_application(headless=headless)
    window = ConsoleWindow(
        session,
        curves=curves,
        settings=settings,
        theme=theme,
        font_scale=font_scale,
    )
    if size is None and headless:
        size = HEADLESS_SIZE  # offscreen there is no screen to size to
    if size is not None:
        window.set_size(*size)
    if headless:
        # Nobody watches an offscreen window's frames go by: painting both cameras at 60 Hz
        # took most of a core (and the GIL) from the measurement and camera threads.
        window.frame_timer.setInterval(OFFSCREEN_FRAME_INTERVAL_MS)
    if screenshot is not None:
        window.screenshot_path = Path(screenshot)
    window.show()
    if duration_s is not None:
        QTimer.singleShot(round(duration_s * 1000), window.close)
    # Ctrl-C in the terminal (or SIGTERM, SIGHUP) closes the window cleanly, recording
    # included; the idle timer lets Python see the signal. An exception raised inside Qt's
    # loop would only be printed, so the CLI's KeyboardInterrupt handlers are set aside.
    # Python runs the handler between any two bytecodes, possibly inside a plot item's paint:
    # the close (which may grab the window for the screenshot) is queued to the event loop,
    # never run inside a paint (a recursive repaint crashed the console there).
    previous = {
        sig: signal.signal(sig, lambda *_: QTimer.singleShot(0, window.close))
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)
    }
    tick = QTimer()
    if until is not None:
        tick.timeout.connect(lambda: window.close() if until.is_set() else None)
    else:
        tick.timeout.connect(lambda: None)
    tick.start(200)
    write_file = None
    if status_file is not None:
        from snrmon.gui.status_file import write_status_file

        # Once a status refresh is complete: every panel shows the snapshot the file reports
        # (its steps are spread over 200 ms; between two, the headers show two snapshots).
        def write_file() -> None:
            write_status_file(window, status_file)

        window.status_refreshed.connect(write_file)
    loop = QEventLoop()
    window.closed.connect(loop.quit)
    try:
        loop.exec()
    finally:
        tick.stop()
        if write_file is not None:
            # The slot refers to the window: left connected, the two would be a cycle that
            # the garbage collector frees later in whatever thread runs it, and a Qt window
            # destroyed outside the GUI thread hangs waiting for the interpreter lock.
            window.status_refreshed.disconnect(write_file)
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    return 0
