"""The console's main window: one panel per camera, the SNR-versus-range plots, the stop table,
status and noise.

Layout (sized for the screen it opens on; a saved layout is restored instead): the camera panels
side by side, under them the stop table (tabbed with the status and noise panels) with room for
the paper's seven stops of both cameras, and on the right, the window's whole height, the
SNR-versus-range plot with at least a third of the window's area. ``P`` puts the range plot in
the images' place and back.
One camera is the active one (outlined; ``C`` switches): the track keys act on it and the range
plot shows it.

Threading (the lessons of acq4#595, PyMoDAQ#79, bluesky#1222): no frames or measurements through
signals; its timers, on the GUI thread, peek each camera's newest frame (60 Hz) and read the
session's status and series (5 Hz; the strip charts 2.5 Hz) and the stop table and range
plots' live points (1 Hz). Qt objects are touched only here.
"""

from __future__ import annotations

import datetime as _dt
import logging
import math
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path

import numpy as np
from PySide6.QtCore import QPoint, QRect, QSettings, QSize, Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QApplication,
    QDockWidget,
    QFileDialog,
    QInputDialog,
    QLabel,
    QMainWindow,
    QScrollArea,
    QSplitter,
    QStackedWidget,
    QTabBar,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from snrmon.acquisition.engine.status import SessionStatus
from snrmon.acquisition.protocols import ConsoleSession, ReplayControls
from snrmon.gui import model_curves as mc
from snrmon.gui import theme as th
from snrmon.gui.actions import ShortcutsDialog, install_actions
from snrmon.gui.alarms import AlarmBanner
from snrmon.gui.camera_panel import CameraPanel
from snrmon.gui.camera_view import PALETTES
from snrmon.gui.frame_feed import DisplayRates, DisplayWorker, FrameFeed, display_message
from snrmon.gui.model_dialog import ModelOptionsDialog
from snrmon.gui.noise_panel import NoisePanel
from snrmon.gui.range_plot import CurveSource, RangePlot
from snrmon.gui.recording_indicator import RecordingIndicator
from snrmon.gui.replay_bar import ReplayBar
from snrmon.gui.status_panel import StatusPanel
from snrmon.gui.stop_table_view import StopTableView
from snrmon.gui.theme import configure_pyqtgraph
from snrmon.gui.window_settings import (
    restore_window,
    save_model_options,
    save_view,
    save_window,
)

# A quarter of the fastest camera's frame period: a tick with no new frame costs a lock and a
# comparison (gui/frame_feed.py); at 16 ms a frame fell between two ticks whenever one was late,
# and MWIR showed 54-57 of its 60 frames a second.
FRAME_INTERVAL_MS = 4
STATUS_INTERVAL_MS = 200  # every panel's status refresh, its steps spread over it
# The strip charts every this many status refreshes (400 ms): a chart's repaint, 1800 dots of
# 30 s at 60 frames/s, its band and its y range fitted again, took 5.6-9 ms of the GUI thread in
# a real window, the console's costliest paint after the images.
CHART_EVERY = 2
TABLE_INTERVAL_MS = 1000
DEFAULT_STOP_ROWS = 14  # the paper's seven stops, both cameras: in view at 1920 x 1080
CAMERAS_MIN_PX = 520  # the camera panels' height the stop table leaves them at the least
STOPS_MIN_FRACTION = 0.26  # of the window's height: the stop table on a small screen
RANGE_PLOT_FRACTION = 0.345  # of the window's area: at least a third, with a margin
INSETS_MIN_PANEL_PX = 420  # a camera panel narrower than this shows no box inset at first

log = logging.getLogger(__name__)


def _no_step() -> None:
    """A status step that shows nothing (a strip chart's, between its refreshes)."""


class ConsoleWindow(QMainWindow):
    """The operator console on a (started) :class:`Session`.

    Args:
        session: the session to display and command; the caller starts and stops it.
        curves: ``curves(camera) -> {name: (ranges_m, snr)}`` from the model, or None; used
            only when there is no predictor (a stand-in, or until the model options apply).
        settings: where geometry and last choices are kept (default: the user's snrmon settings).
        theme: "dark" or "daylight" (default: the saved choice, else dark).
        font_scale: every text's size over the console's normal (default: the saved one, else 1).
    """

    closed = Signal()
    status_refreshed = Signal()  # every panel shows the same status snapshot (last_status)

    def __init__(
        self,
        session: ConsoleSession,
        *,
        curves: CurveSource | None = None,
        settings: QSettings | None = None,
        theme: str | None = None,
        font_scale: float | None = None,
    ) -> None:
        configure_pyqtgraph()
        super().__init__()
        self.session = session
        self.curves_source = curves
        self.model: mc.ModelCurves | None = mc.model_for_session(session)
        self._model_version: tuple[int, int] | None = None  # of the curves drawn
        self.model_dialog: ModelOptionsDialog | None = None
        self.settings = settings or QSettings("snrmon", "console")
        self.screenshot_path: Path | None = None
        self.last_status: SessionStatus | None = None
        self._curves_due = False  # the model's curves changed since they were drawn
        self._status_steps_left: list[Callable[[], None]] = []  # of the refresh under way
        self._status_refreshes = 0  # begun by the status timer
        self.messages: list[str] = []
        self._curves: dict[str, dict] = {}
        self._pixels: dict[str, np.ndarray] = {}
        self.theme_name = th.current().name
        self.font_scale = 1.0
        self.large: str | None = None  # the panel in the images' place: "range", "stops"
        self.insets_shown = True
        self.setWindowTitle("snrmon console")
        self._build_cameras(session)
        self._build_docks(session)
        self.replay = isinstance(session, ReplayControls)
        self.shown_counter: dict[str, int] = {}
        self.actions_by_key = install_actions(self, self.menuBar(), replay=self.replay)
        self.replay_bar: ReplayBar | None = None
        self.shortcuts_dialog: ShortcutsDialog | None = None  # F1, made when first asked for
        if self.replay:
            self.replay_bar = ReplayBar(session, self.actions_by_key, self)
            self.addToolBar(Qt.ToolBarArea.TopToolBarArea, self.replay_bar)
        view_menu = self.menuBar().addMenu("&Panels")
        for dock in self.findChildren(QDockWidget):
            view_menu.addAction(dock.toggleViewAction())
        self._build_status_bar(session)

        self.reload_curves()
        self._layout_pending = restore_window(self)  # True: a first start, fit the docks
        self.layout_fitted = not self._layout_pending
        self.set_view(
            theme if theme is not None else self.theme_name,
            font_scale if font_scale is not None else self.font_scale,
            save=False,
        )
        self._mark_active()
        self._timers = self._started_timers()
        self.frame_timer = self._timers[0]  # offscreen, run_console slows it

    def _build_cameras(self, session: ConsoleSession) -> None:
        """The alarm banner over the camera panels, side by side (the central widget)."""
        self.banner = AlarmBanner()
        self.panels: dict[str, CameraPanel] = {}
        self.camera_splitter = QSplitter(Qt.Orientation.Horizontal)
        self.camera_splitter.setChildrenCollapsible(False)
        for name, pipe in session.pipelines.items():
            panel = CameraPanel(name, pipe.shape, session.config.measurement)
            panel.view.roi_clicked.connect(self.set_roi)
            panel.view.pointed.connect(self._show_pointed)
            self.panels[name] = panel
            self.camera_splitter.addWidget(panel)
        self.active_camera = next(iter(self.panels), "")
        self.central_stack = QStackedWidget()
        self.central_stack.addWidget(self.camera_splitter)
        central = QWidget()
        lay = QVBoxLayout(central)
        lay.setContentsMargins(2, 2, 2, 2)
        lay.addWidget(self.banner)
        lay.addWidget(self.central_stack, 1)
        self.setCentralWidget(central)

    def _build_docks(self, session: ConsoleSession) -> None:
        """The range plots on the right, the window's whole height; the stop table, status and
        noise tabbed under the cameras."""
        self.setCorner(Qt.Corner.TopRightCorner, Qt.DockWidgetArea.RightDockWidgetArea)
        self.setCorner(Qt.Corner.BottomRightCorner, Qt.DockWidgetArea.RightDockWidgetArea)
        self.setCorner(Qt.Corner.BottomLeftCorner, Qt.DockWidgetArea.BottomDockWidgetArea)
        self.range_tabs = QTabWidget()
        self.range_tabs.setDocumentMode(True)
        self.range_plots = {name: RangePlot(name) for name in session.pipelines}
        for name, plot in self.range_plots.items():
            self.range_tabs.addTab(plot, f"SNR vs range: {name.upper()}")
        self.range_tabs.currentChanged.connect(self._range_tab_changed)
        right = Qt.DockWidgetArea.RightDockWidgetArea
        self.range_dock = self._dock("range", "SNR vs range", self.range_tabs, right)
        bottom = Qt.DockWidgetArea.BottomDockWidgetArea
        self.stop_table = StopTableView()
        self.stops_dock = self._dock("stops", "Stops", self.stop_table, bottom)
        self.status_panel = StatusPanel(list(session.pipelines))
        scroll = QScrollArea()
        scroll.setWidget(self.status_panel)
        scroll.setWidgetResizable(True)
        self.status_dock = self._dock("status", "Status", scroll, bottom)
        self.noise_panel = NoisePanel(list(session.pipelines))
        self.noise_dock = self._dock("noise", "Noise", self.noise_panel, bottom)
        self.tabifyDockWidget(self.stops_dock, self.status_dock)
        self.tabifyDockWidget(self.status_dock, self.noise_dock)
        self.stops_dock.raise_()
        # Room for the data: the tabs name the range plot's and the bottom docks' contents, so
        # their title bars go (the Panels menu still shows and hides each).
        self.setTabPosition(bottom, QTabWidget.TabPosition.North)
        for dock in (self.range_dock, self.stops_dock, self.status_dock, self.noise_dock):
            dock.setTitleBarWidget(QWidget())
        self.toggle_noise_panel = self.noise_dock.toggleViewAction().trigger  # Ctrl+Shift+N

    def _build_status_bar(self, session: ConsoleSession) -> None:
        """The pointer's pixel, the recording indicator and the frames shown / delivered (the
        frame feeds and the display worker that fills them start here)."""
        self.recording_label = RecordingIndicator()
        self.pointer_label = QLabel("")
        self.pointer_label.setToolTip(
            "The pixel under the pointer and its value in the shown frame"
        )
        self.statusBar().addPermanentWidget(self.pointer_label)
        self.statusBar().addPermanentWidget(self.recording_label)
        self.statusBar().showMessage("ready: click a drone to set its ROI")
        # Frames shown / delivered per camera (refresh_frames, refresh_status).
        self.feeds = {name: FrameFeed(pipe) for name, pipe in session.pipelines.items()}
        self.display_worker = DisplayWorker(self.feeds.values())
        self.display_worker.start()
        self.display_rates = DisplayRates()
        self.display_label = QLabel()
        self.statusBar().addPermanentWidget(self.display_label)

    def _started_timers(self) -> list[QTimer]:
        """The frame, status-step and table timers, started (precise: a coarse timer may fire
        up to 5 % of its interval late)."""
        timers = []
        status_step_ms = max(STATUS_INTERVAL_MS // len(self._status_steps()), 1)
        for interval, slot in (
            (FRAME_INTERVAL_MS, self.refresh_frames),
            (status_step_ms, self._refresh_status_step),
            (TABLE_INTERVAL_MS, self.refresh_stops),
        ):
            timer = QTimer(self)
            timer.setTimerType(Qt.TimerType.PreciseTimer)
            timer.timeout.connect(slot)
            timer.start(interval)
            timers.append(timer)
        return timers

    def _dock(self, key: str, title: str, widget: QWidget, area) -> QDockWidget:
        dock = QDockWidget(title, self)
        dock.setObjectName(f"dock_{key}")  # saveState needs names
        dock.setWidget(widget)
        self.addDockWidget(area, dock)
        return dock

    # ------------------------------------------------------------------ layout
    def showEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        super().showEvent(event)
        if self._layout_pending:
            self._layout_pending = False
            # After the first layout pass: the docks' title bars and tabs have their sizes.
            QTimer.singleShot(0, self.fit_default_layout)

    def fit_default_layout(self, again: bool = False) -> None:
        """The first start's proportions for this window's size: the stop table as high as
        :data:`DEFAULT_STOP_ROWS` rows need where the cameras keep :data:`CAMERAS_MIN_PX`
        (on a smaller screen :data:`STOPS_MIN_FRACTION` of the height; the table scrolls),
        then the range plot as wide as :data:`RANGE_PLOT_FRACTION` of the window's area needs
        at its height."""
        table = self.stop_table
        # The table's header grows to three lines once the model's columns arrive.
        header = table.horizontalHeader()
        three_lines = 3 * table.fontMetrics().lineSpacing() + 8
        chrome = self.stops_dock.height() - table.viewport().height()
        chrome += max(three_lines - header.height(), 0)
        rows_h = DEFAULT_STOP_ROWS * table.verticalHeader().defaultSectionSize()
        tabs = sum(
            bar.height()
            for bar in self.findChildren(QTabBar)
            if bar.parentWidget() is self and bar.isVisible()
        )
        top = self.height() - self.centralWidget().height() - self.stops_dock.height() - tabs
        room = max(self.height() - top - CAMERAS_MIN_PX, int(STOPS_MIN_FRACTION * self.height()))
        # (the size asked of tabbed docks is that of the dock and its tab bar together)
        want = min(rows_h + chrome + 2 + tabs, room)
        self.resizeDocks([self.stops_dock], [want], Qt.Orientation.Vertical)
        self.layout_fitted = again
        if not again:
            # Once the range plot has its width the camera panels have theirs, and with it the
            # headers' final height: the table's height is set once more then.
            QTimer.singleShot(0, self._fit_range_width)

    def _fit_range_width(self) -> None:
        plot = self.range_plots.get(self.active_camera)
        if plot is None or self.range_large:
            return
        area = RANGE_PLOT_FRACTION * self.width() * self.height()
        chrome = self.range_dock.width() - plot.width()
        want = int(area / max(plot.height(), 1)) + chrome
        want = min(max(want, int(0.4 * self.width())), int(0.62 * self.width()))
        self.resizeDocks([self.range_dock], [want], Qt.Orientation.Horizontal)
        QTimer.singleShot(0, self._fit_insets)
        QTimer.singleShot(0, lambda: self.fit_default_layout(again=True))

    def _fit_insets(self) -> None:
        # The box insets only where the panels have room for them beside a strip chart.
        width = min((p.width() for p in self.panels.values()), default=0)
        self.set_insets(width >= INSETS_MIN_PANEL_PX)

    def set_insets(self, shown: bool) -> None:
        self.insets_shown = shown
        for panel in self.panels.values():
            panel.show_insets(shown)

    def toggle_insets(self) -> None:
        self.set_insets(not self.insets_shown)
        self.report("box insets shown" if self.insets_shown else "box insets hidden (I: back)")

    def set_size(self, width: int, height: int) -> None:
        """The window at ``width`` x ``height`` pixels from its screen's top left corner, not
        maximised (a first start maximises it over the screen)."""
        if not (width > 0 and height > 0):
            raise ValueError(f"window size must be positive pixels, got {width} x {height}")
        self.setWindowState(Qt.WindowState.WindowNoState)
        screen = self.screen()
        corner = screen.availableGeometry().topLeft() if screen is not None else QPoint(0, 0)
        self.setGeometry(QRect(corner, QSize(width, height)))

    @property
    def range_large(self) -> bool:
        """The SNR-versus-range plot is in the images' place."""
        return self.large == "range"

    def toggle_range_large(self) -> None:
        """The SNR-versus-range plot in the images' place, or back in its dock."""
        self.enlarge(None if self.large == "range" else "range")
        self.report("SNR vs range enlarged (P: back)" if self.large else "images back")

    def toggle_stops_large(self) -> None:
        """The stop table in the images' place (every stop in view on a laptop's screen), or
        back in its dock."""
        self.enlarge(None if self.large == "stops" else "stops")
        self.report("stop table enlarged (S: back)" if self.large else "images back")

    def enlarge(self, which: str | None) -> None:
        """Put the panel ``which`` ("range": the SNR-versus-range plot, "stops": the stop
        table) in the images' place, the one there before back in its dock; None: the images."""
        panels = {
            "range": (self.range_dock, self.range_tabs),
            "stops": (self.stops_dock, self.stop_table),
        }
        if which is not None and which not in panels:
            raise ValueError(f"no panel {which!r} to enlarge ({', '.join(panels)})")
        if self.large is not None:
            dock, widget = panels[self.large]
            self.central_stack.removeWidget(widget)
            dock.setWidget(widget)
            dock.show()
            dock.raise_()  # the front tab again where it is tabbed with others
            self.central_stack.setCurrentWidget(self.camera_splitter)
        if which is not None:
            dock, widget = panels[which]
            dock.hide()
            self.central_stack.addWidget(widget)
            self.central_stack.setCurrentWidget(widget)
        self.large = which

    def switch_camera(self) -> None:
        """The next camera becomes the active one."""
        names = list(self.panels)
        if not names:
            return
        self.set_active_camera(names[(names.index(self.active_camera) + 1) % len(names)])
        self.report(f"active camera: {self.active_camera}")

    def set_active_camera(self, name: str) -> None:
        if name in self.panels:
            self.active_camera = name
            self._mark_active()

    def _mark_active(self) -> None:
        for name, panel in self.panels.items():
            panel.header.set_active(name == self.active_camera)
        if self.active_camera in self.range_plots:
            index = list(self.range_plots).index(self.active_camera)
            if self.range_tabs.currentIndex() != index:
                self.range_tabs.setCurrentIndex(index)

    def _range_tab_changed(self, index: int) -> None:
        names = list(self.range_plots)
        if 0 <= index < len(names) and names[index] != self.active_camera:
            self.set_active_camera(names[index])

    # ------------------------------------------------------------------ theme and text size
    def set_view(self, theme: str, font_scale: float, *, save: bool = True) -> None:
        """Switch to ``theme`` ("dark", "daylight") at ``font_scale``; every panel restyled."""
        chosen = th.theme_named(theme)
        scale = th.check_font_scale(font_scale)
        app = QApplication.instance()
        if app is not None:
            th.apply_theme(app, chosen, scale)
        self.theme_name, self.font_scale = chosen.name, scale
        font = th.scaled_font(scale)
        for panel in self.panels.values():
            panel.apply_theme(scale)
        for plot in self.range_plots.values():
            plot.apply_theme(font)
        self.stop_table.apply_theme()
        self.banner.setFont(th.scaled_font(scale, 1.2, bold=True))
        if save:
            save_view(self.settings, chosen.name, scale)

    def toggle_daylight(self) -> None:
        self.set_view("dark" if self.theme_name == "daylight" else "daylight", self.font_scale)
        self.report(f"theme: {self.theme_name}")

    def _step_font(self, step: int) -> None:
        scales = th.FONT_SCALES
        i = min(range(len(scales)), key=lambda k: abs(scales[k] - self.font_scale))
        self.set_view(self.theme_name, scales[min(max(i + step, 0), len(scales) - 1)])
        self.report(f"text at {self.font_scale:g} x")

    def font_larger(self) -> None:
        self._step_font(+1)

    def font_smaller(self) -> None:
        self._step_font(-1)

    def font_reset(self) -> None:
        self.set_view(self.theme_name, 1.0)
        self.report("text at 1 x")

    # ------------------------------------------------------------------ settings
    def save_settings(self) -> None:
        if self.large is not None:
            self.enlarge(None)  # the dock layout is saved with every panel in its dock
        save_window(self)

    # ------------------------------------------------------------------ refresh (GUI thread)
    def refresh_frames(self) -> None:
        """Show each camera's frame if it has a new one (gui/frame_feed.py)."""
        for name, panel in self.panels.items():
            feed = self.feeds[name]
            shown = feed.newest()
            if shown is not None and panel.view.show_frame(shown):
                self._pixels[name] = shown.frame.pixels
                self.shown_counter[name] = shown.frame.counter
                # how the view drew it, for the worker's next (a tick without a new frame, 4
                # in 5 of them, asks nothing: it costs a lock and a comparison)
                feed.request = panel.view.display_request()
            elif feed.request is None:
                feed.request = panel.view.display_request()
        if self.replay_bar is not None:
            self.replay_bar.show_position()

    def show_display_rates(self) -> None:
        """The status bar's frames shown / delivered per second (amber while skipping)."""
        text, skipping = display_message(self.display_rates.sample(self.feeds))
        self.display_label.setText(text)
        self.display_label.setStyleSheet("color: #ffb000;" if skipping else "")

    def refresh_status(self) -> None:
        """Show the session's status in every panel, all of it now (an action's immediate
        answer; tests)."""
        for step in self._status_steps():
            step()
        self._status_steps_left = []  # a refresh under way is complete now
        self.status_refreshed.emit()

    def _refresh_status_step(self) -> None:
        """The status timer's tick: the next step of the refresh (:meth:`_status_steps`).

        The steps of one refresh are spread evenly over :data:`STATUS_INTERVAL_MS`, each with
        the paints it asks for (a strip chart, an inset, a header) running before the next
        step, with frames between them. Run back to back, a refresh and its paints held the
        event loop for 20-30 ms of the GUI thread's CPU every 200 ms: the late ticks of a
        10 ms timer were all in such bursts."""
        if not self._status_steps_left:
            self._status_refreshes += 1
            charts = self._status_refreshes % CHART_EVERY == 0
            self._status_steps_left = self._status_steps(charts=charts)
        self._status_steps_left.pop(0)()
        if not self._status_steps_left:
            self.status_refreshed.emit()

    def _status_steps(self, *, charts: bool = True) -> list[Callable[[], None]]:
        """The status refresh in steps: the session's status and the shared panels, then for
        each camera its panels, and its strip chart unless not ``charts`` (its step then
        passes: the steps keep their spacing). The range plots follow the stop table, once a
        second (:meth:`refresh_stops`)."""
        steps: list[Callable[[], None]] = [self._show_session_status]
        for name in self.panels:
            chart = partial(self._show_chart, name) if charts else _no_step
            steps += [partial(self._show_camera_status, name), chart]
        return steps

    def _now_ns(self) -> int:
        """Now on the status's clock: a replay's is the recorded time of its shown frame."""
        return self.session.now_ns() if self.replay else time.monotonic_ns()

    def _show_session_status(self) -> None:
        self.show_display_rates()
        st = self.session.status()
        self.last_status = st
        self.banner.show_alarms(st.alarms, self._now_ns() / 1e9)
        self.status_panel.show_status(st)
        self.noise_panel.show_status(st)
        version = self.model.version if self.model is not None else None
        self._curves_due = version is not None and version != self._model_version
        self._model_version = version
        self._show_recording(st)

    def _show_camera_status(self, name: str) -> None:
        st = self.last_status
        if st is None or name not in st.cameras:
            return
        panel, cs = self.panels[name], st.cameras[name]
        followed = self.model is not None and self.model.sky_changed(
            name, self.session.model_sky_temp_k(name)
        )
        if followed or self._curves_due:  # a new sky, or curves computed in the background
            self._draw_curves(name)
        panel.view.show_status(cs)
        for message in self.session.pipelines[name].click_messages():
            self.report(f"{name}: {message}")  # what the track made of a click
        panel.inset.show_box(self._pixels.get(name), cs)
        a = cs.agreement
        panel.header.show_status(cs, st)
        panel.place()  # the header's height may follow its new words
        self.range_plots[name].set_rule(a.rule if a else None)

    def _show_chart(self, name: str) -> None:
        """``name``'s strip chart: its series up to now, the model's reading at its range."""
        st = self.last_status
        if st is None or name not in st.cameras:
            return
        chart = self.panels[name].chart
        chart.show_series(self.session.pipelines[name].series(), self._now_ns())
        a = st.cameras[name].agreement
        chart.show_model(a.rule if a else "", a.expected if a else None)

    def _show_recording(self, st: SessionStatus) -> None:
        rec = st.recording
        recording = rec.state == "recording"
        self.actions_by_key["record_start"].setEnabled(not recording)
        self.actions_by_key["record_stop"].setEnabled(recording)
        self.recording_label.show_recording(rec)

    def refresh_stops(self) -> None:
        """The stop table and each range plot's stops, and its live point (once a second: a
        range plot's repaint, its y range fitted again, takes 14-50 ms of the GUI thread in a
        real window, the longest paint of the console; at the status's 5 a second it was the
        event loop's longest wait)."""
        rows = self.session.stops()
        self.stop_table.show_rows(rows)
        st = self.last_status
        for name, plot in self.range_plots.items():
            plot.show_stops(rows)
            cs = st.cameras.get(name) if st is not None else None
            if cs is not None and cs.last is not None:
                plot.show_live(cs.last.range_m, cs.last.snr_mean, cs.snr_sem)

    def reload_curves(self) -> None:
        """Ask the model (or the injected source) for each camera's curves (not per frame)."""
        for name in self.range_plots:
            self._draw_curves(name)

    def _draw_curves(self, name: str) -> None:
        source = self.model.curves if self.model is not None else self.curves_source
        curves = None
        if source is not None:
            try:
                curves = source(name)
            except (ValueError, OSError, KeyError) as exc:
                self.report(f"model curves for {name}: {exc}")
        self._curves[name] = dict(curves or {})
        try:
            self.range_plots[name].set_curves(curves)
        except ValueError as exc:
            self.report(str(exc))

    def model_options(self) -> ModelOptionsDialog:
        """Open the model options dialog (non-modal)."""
        if self.model_dialog is None:
            options = self.model.options if self.model else mc.default_options(self.session)
            self.model_dialog = ModelOptionsDialog(options, self.apply_model_options, self)
        self.model_dialog.show()
        return self.model_dialog

    def apply_model_options(self, options: mc.ModelOptions) -> str | None:
        """Ask the session for the model of ``options``, redraw; the refusal's message or None.
        With the measured noise, each camera's latest 3D noise goes into the model (a camera
        without one keeps the model's noise: the message names it)."""
        noise, kept = mc.measured_noise_now(self.session, options)
        try:
            self.model = mc.applied_model(self.model, self.session, options, noise)
        except (ValueError, OSError, KeyError) as exc:
            self.report(message := f"model options refused: {exc}")
            return message
        self.reload_curves()
        save_model_options(self.settings, options)
        per_camera = mc.describe_noise(noise, kept)
        self.report(f"model: {mc.describe(options)}" + (f"; {per_camera}" if per_camera else ""))
        return None

    # ------------------------------------------------------------------ commands
    def report(self, message: str) -> None:
        """An operator-facing message (status bar, the message log, and the process's log: a
        recording's FILE.log keeps what the operator did and was told)."""
        log.info(message)
        self.messages.append(message)
        self.statusBar().showMessage(message, 10_000)

    def set_roi(self, camera: str, x: int, y: int) -> None:
        self.set_active_camera(camera)  # the camera clicked is the one the track keys act on
        try:
            self.session.set_roi(camera, x, y)
        except ValueError as exc:
            self.report(str(exc))
            return
        self.report(f"{camera}: ROI set at column {x}, row {y}")

    def reselect_track(self) -> None:
        """The active camera's ROI set again where the drone is: its GPS position projected
        into the camera, else the last measured peak."""
        name = self.active_camera
        st = self.last_status
        cs = st.cameras.get(name) if st is not None else None
        where = None
        if cs is not None and cs.gps_xy is not None and all(math.isfinite(v) for v in cs.gps_xy):
            where, why = cs.gps_xy, "the GPS position"
        elif cs is not None and cs.last is not None:
            where, why = (cs.last.result.peak_x, cs.last.result.peak_y), "the last peak"
        if where is None:
            self.report(f"{name}: nothing to re-select (no GPS position, no measurement): click")
            return
        x, y = round(where[0]), round(where[1])
        self.set_roi(name, x, y)
        self.report(f"{name}: track re-selected at {why} (column {x}, row {y})")

    def release_track(self) -> None:
        """Stop measuring on the active camera (until the next click)."""
        name = self.active_camera
        try:
            self.session.clear_roi(name)
        except ValueError as exc:
            self.report(f"{name}: track not released: {exc}")
            return
        self.report(f"{name}: track released")

    def mark_event(self) -> None:
        """A timestamped "event" note in the record, without a dialog."""
        self.add_note("event")

    def copy_stops(self) -> None:
        n = self.stop_table.copy_csv()
        self.report(f"{n} stop rows copied to the clipboard as CSV")

    def start_recording(self, path: str | Path | None = None) -> bool:
        """Start recording into ``path`` (asks with a file dialog when None)."""
        if path is None:
            folder = self.settings.value("recording/dir", str(Path.cwd()))
            stamp = _dt.datetime.now().strftime("%Y%m%d-%H%M%S")
            chosen, _ = QFileDialog.getSaveFileName(
                self,
                "Record session",
                str(Path(folder) / f"session-{stamp}.h5"),
                "Session files (*.h5)",
            )
            if not chosen:
                return False
            path = chosen
        path = Path(path)
        try:
            self.session.start_recording(path)
        except (ValueError, OSError) as exc:
            self.report(f"recording not started: {exc}")
            return False
        self.settings.setValue("recording/dir", str(path.parent))
        self.report(f"recording to {path}")
        self.refresh_status()
        return True

    def stop_recording(self) -> None:
        summary = self.session.stop_recording()
        self.report("recording stopped" if summary is not None else "not recording")
        self.refresh_status()

    def mark_stop(self) -> None:
        try:
            self.session.mark_stop()
        except ValueError as exc:
            self.report(f"stop not marked: {exc}")
            return
        self.report("stop marked")
        self.refresh_stops()

    def capture_reference(self, n_frames: int = 64) -> None:
        try:
            for name in self.panels:
                self.session.capture_reference(name, n_frames)
        except ValueError as exc:
            self.report(f"no background reference: {exc}")
            return
        self.report(f"capturing a {n_frames}-frame background reference on every camera")

    def add_note(self, text: str | None = None) -> None:
        if text is None:
            text, ok = QInputDialog.getText(self, "Note", "Note for the record:")
            if not ok:
                return
        if text.strip():
            try:
                self.session.add_note(text.strip())
            except ValueError as exc:
                self.report(f"note not added: {exc}")
                return
            self.report(f"note: {text.strip()}")

    # ------------------------------------------------------------------ replay controls
    def replay_toggle(self) -> None:
        self.session.toggle_play()

    def replay_step(self) -> None:
        self.session.step()

    def replay_back(self) -> None:
        self.session.seek(max(self.session.position().index - 1, 0))

    def replay_home(self) -> None:
        self.session.seek(0)

    def replay_faster(self) -> None:
        self.replay_bar.change_speed(up=True)

    def replay_slower(self) -> None:
        self.replay_bar.change_speed(up=False)

    def _show_pointed(self, camera: str, x: int, y: int, dn: float) -> None:
        """The pixel under the pointer, its DN and, with a calibration, its apparent
        temperature (the session's conversion)."""
        temp_k = self.session.pipelines[camera].apparent_temp_k(x, y, dn)
        temp = "" if temp_k is None else f", apparent {temp_k:.2f} K ({temp_k - 273.15:.2f} C)"
        self.pointer_label.setText(f"{camera} column {x}, row {y}: {dn:.0f} DN{temp}")

    def next_palette(self) -> None:
        """Every camera's image in the next palette (grey, white-hot, black-hot, ironbow)."""
        names = list(PALETTES)
        first = next(iter(self.panels.values())).view.palette
        name = names[(names.index(first) + 1) % len(names)]
        for panel in self.panels.values():
            panel.view.set_palette(name)
        self.report(f"palette: {name}")

    def auto_levels(self) -> None:
        for panel in self.panels.values():
            panel.view.set_auto_levels(True)

    def reset_zoom(self) -> None:
        for panel in self.panels.values():
            panel.view.reset_zoom()

    def toggle_fullscreen(self) -> None:
        self.showNormal() if self.isFullScreen() else self.showFullScreen()

    def show_shortcuts(self) -> None:
        if self.shortcuts_dialog is None:
            self.shortcuts_dialog = ShortcutsDialog(self)
        self.shortcuts_dialog.show()
        self.shortcuts_dialog.raise_()

    def save_screenshot(self, path: str | Path | None = None) -> Path | None:
        """Save the whole window as a PNG (asks for a file name when None)."""
        if path is None:
            chosen, _ = QFileDialog.getSaveFileName(
                self, "Save screenshot", "snrmon-console.png", "PNG (*.png)"
            )
            if not chosen:
                return None
            path = chosen
        path = Path(path)
        QApplication.processEvents()  # GUI thread: let pending paints land before grabbing
        if not self.grab().save(str(path), "PNG"):
            self.report(f"screenshot not saved: cannot write {path}")
            return None
        return path

    def closeEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        if self.screenshot_path is not None:
            self.save_screenshot(self.screenshot_path)
        for timer in self._timers:
            timer.stop()
        self.display_worker.stop()
        if self.session.status().recording.state == "recording":
            self.session.stop_recording()
        self.save_settings()
        super().closeEvent(event)
        self.closed.emit()
