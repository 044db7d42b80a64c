"""The console's main window: one panel per camera, status, stop table, SNR-versus-range plots.

Threading (the lessons of acq4#595, PyMoDAQ#79, bluesky#1222): no frames or measurements through
signals; its timers, on the GUI thread, peek each camera's newest frame (60 Hz) and read the
session's status, series and stop table (5 Hz / 1 Hz). Qt objects are touched only here.
"""

from __future__ import annotations

import datetime as _dt
import logging
import time
from pathlib import Path

import numpy as np
from PySide6.QtCore import QSettings, Qt, QTimer, Signal
from PySide6.QtWidgets import (
    QApplication,
    QDockWidget,
    QFileDialog,
    QInputDialog,
    QLabel,
    QMainWindow,
    QMessageBox,
    QScrollArea,
    QSplitter,
    QTabWidget,
    QVBoxLayout,
    QWidget,
)

from snrmon.acquisition.engine.status import SessionStatus
from snrmon.acquisition.prediction import EXPECTED
from snrmon.acquisition.protocols import ConsoleSession, ReplayControls
from snrmon.gui import model_curves as mc
from snrmon.gui.actions import install_actions, shortcuts_text
from snrmon.gui.alarms import AlarmBanner
from snrmon.gui.camera_panel import CameraPanel
from snrmon.gui.frame_feed import DisplayRates, FrameFeed, display_message
from snrmon.gui.model_dialog import ModelOptionsDialog
from snrmon.gui.noise_panel import NoisePanel
from snrmon.gui.range_plot import CurveSource, RangePlot
from snrmon.gui.replay_bar import ReplayBar
from snrmon.gui.status_panel import StatusPanel
from snrmon.gui.stop_table_view import StopTableView
from snrmon.gui.theme import configure_pyqtgraph
from snrmon.gui.window_settings import restore_window, save_model_options, save_window

# A quarter of the fastest camera's frame period: a tick with no new frame costs a lock and a
# comparison (gui/frame_feed.py); at 16 ms a frame fell between two ticks whenever one was late,
# and MWIR showed 54-57 of its 60 frames a second.
FRAME_INTERVAL_MS = 4
STATUS_INTERVAL_MS = 200
TABLE_INTERVAL_MS = 1000

log = logging.getLogger(__name__)


class ConsoleWindow(QMainWindow):
    """The operator console on a (started) :class:`Session`.

    Args:
        session: the session to display and command; the caller starts and stops it.
        curves: ``curves(camera) -> {name: (ranges_m, snr)}`` from the model, or None; used
            only when there is no predictor (a stand-in, or until the model options apply).
        predictor: the :class:`snrmon.acquisition.prediction.ModelPredictor` (default: the
            session's); the model options dialog rebuilds it and hands it to the session.
        settings: where geometry and last choices are kept (default: the user's snrmon settings).
    """

    closed = Signal()

    def __init__(
        self,
        session: ConsoleSession,
        *,
        curves: CurveSource | None = None,
        predictor=None,
        settings: QSettings | None = None,
    ) -> None:
        configure_pyqtgraph()
        super().__init__()
        self.session = session
        self.curves_source = curves
        self.model: mc.ModelCurves | None = mc.model_for_session(session, predictor)
        self._model_version: tuple[int, int] | None = None  # of the curves drawn
        self.model_dialog: ModelOptionsDialog | None = None
        self.settings = settings or QSettings("snrmon", "console")
        self.screenshot_path: Path | None = None
        self.last_status: SessionStatus | None = None
        self.messages: list[str] = []
        self._curves: dict[str, dict] = {}
        self._pixels: dict[str, np.ndarray] = {}
        self.setWindowTitle("snrmon console")

        self.banner = AlarmBanner()
        self.panels: dict[str, CameraPanel] = {}
        splitter = QSplitter(Qt.Orientation.Horizontal)
        for name, pipe in session.pipelines.items():
            panel = CameraPanel(name, pipe.shape, session.config.measurement)
            panel.view.roi_clicked.connect(self.set_roi)
            self.panels[name] = panel
            splitter.addWidget(panel)
        central = QWidget()
        lay = QVBoxLayout(central)
        lay.setContentsMargins(2, 2, 2, 2)
        lay.addWidget(self.banner)
        lay.addWidget(splitter, 1)
        self.setCentralWidget(central)

        self.status_panel = StatusPanel(list(session.pipelines))
        scroll = QScrollArea()
        scroll.setWidget(self.status_panel)
        scroll.setWidgetResizable(True)
        self._dock("status", "Status", scroll, Qt.DockWidgetArea.RightDockWidgetArea)
        self.range_tabs = QTabWidget()
        self.range_plots = {name: RangePlot(name) for name in session.pipelines}
        for name, plot in self.range_plots.items():
            self.range_tabs.addTab(plot, f"SNR vs range: {name}")
        self._dock("range", "SNR vs range", self.range_tabs, Qt.DockWidgetArea.RightDockWidgetArea)
        self.noise_panel = NoisePanel(list(session.pipelines))
        dock = self._dock("noise", "Noise", self.noise_panel, Qt.DockWidgetArea.RightDockWidgetArea)
        self.toggle_noise_panel = dock.toggleViewAction().trigger  # the Ctrl+Shift+N action
        self.stop_table = StopTableView()
        bottom = Qt.DockWidgetArea.BottomDockWidgetArea
        stops = self._dock("stops", "Stops", self.stop_table, bottom)
        self.resizeDocks([stops], [150], Qt.Orientation.Vertical)  # the images need the height

        self.replay = isinstance(session, ReplayControls)
        self.shown_counter: dict[str, int] = {}
        self.actions_by_key = install_actions(self, self.menuBar(), replay=self.replay)
        self.replay_bar: ReplayBar | None = None
        if self.replay:
            self.replay_bar = ReplayBar(session, self.actions_by_key, self)
            self.addToolBar(Qt.ToolBarArea.TopToolBarArea, self.replay_bar)
        view_menu = self.menuBar().addMenu("&Panels")
        for dock in self.findChildren(QDockWidget):
            view_menu.addAction(dock.toggleViewAction())
        self.statusBar().showMessage("ready: click a drone to set its ROI")
        # Frames shown / delivered per camera (refresh_frames, refresh_status).
        self.feeds = {name: FrameFeed(pipe) for name, pipe in session.pipelines.items()}
        self.display_rates = DisplayRates()
        self.display_label = QLabel()
        self.statusBar().addPermanentWidget(self.display_label)

        self.reload_curves()
        restore_window(self)
        self._timers = []
        for interval, slot in (
            (FRAME_INTERVAL_MS, self.refresh_frames),
            (STATUS_INTERVAL_MS, self.refresh_status),
            (TABLE_INTERVAL_MS, self.refresh_stops),
        ):
            timer = QTimer(self)
            timer.setTimerType(Qt.TimerType.PreciseTimer)
            timer.timeout.connect(slot)
            timer.start(interval)
            self._timers.append(timer)
        self.frame_timer = self._timers[0]  # offscreen, run_console slows it

    def _dock(self, key: str, title: str, widget: QWidget, area) -> QDockWidget:
        dock = QDockWidget(title, self)
        dock.setObjectName(f"dock_{key}")  # saveState needs names
        dock.setWidget(widget)
        self.addDockWidget(area, dock)
        return dock

    # ------------------------------------------------------------------ settings
    def save_settings(self) -> None:
        save_window(self)

    # ------------------------------------------------------------------ refresh (GUI thread)
    def refresh_frames(self) -> None:
        """Show each camera's frame if it has a new one (gui/frame_feed.py)."""
        for name, panel in self.panels.items():
            frame = self.feeds[name].newest()
            if frame is not None and panel.view.show_frame(frame):
                self._pixels[name] = frame.pixels
                self.shown_counter[name] = frame.counter
        if self.replay_bar is not None:
            self.replay_bar.show_position()

    def show_display_rates(self) -> None:
        """The status bar's frames shown / delivered per second (amber while skipping)."""
        text, skipping = display_message(self.display_rates.sample(self.feeds))
        self.display_label.setText(text)
        self.display_label.setStyleSheet("color: #ffb000;" if skipping else "")

    def refresh_status(self) -> None:
        self.show_display_rates()
        st = self.session.status()
        self.last_status = st
        # A replay's "now" is the recorded time of its shown frame.
        now_ns = self.session.now_ns() if self.replay else time.monotonic_ns()
        self.banner.show_alarms(st.alarms, now_ns / 1e9)
        self.status_panel.show_status(st)
        self.noise_panel.show_status(st)
        version = self.model.version if self.model is not None else None
        redraw = version is not None and version != self._model_version
        self._model_version = version
        for name, panel in self.panels.items():
            cs = st.cameras[name]
            followed = self.model is not None and self.model.follow_sky(name, cs.figures.sky_temp_k)
            if followed or redraw:  # a new sky, or curves computed in the background arrived
                self._draw_curves(name)
            panel.view.show_status(cs)
            for message in self.session.pipelines[name].click_messages():
                self.report(f"{name}: {message}")  # what the track made of a click
            panel.inset.show_box(self._pixels.get(name), cs)
            panel.chart.show_series(self.session.pipelines[name].series(), now_ns)
            mname, msnr = self._model_now(cs)
            panel.chart.show_model(mname, msnr)
            m, fig = cs.last, cs.figures
            if m is not None:
                self.range_plots[name].show_live(m.range_m, m.snr_mean, m.snr_std)
            snr = f"{m.snr_mean:.2f} +/- {m.snr_std:.2f}" if m is not None and m.snr_n else "--"
            if m is not None and fig.reference_frames and m.snr_mean_raw == m.snr_mean_raw:
                snr += f" (raw {m.snr_mean_raw:.2f}, FPN {fig.fixed_pattern_dn:.1f} DN)"
            if fig.sky_temp_k == fig.sky_temp_k:  # not NaN
                snr += f"   sky {fig.sky_temp_k - 273.15:.1f} C"
            panel.header.setText(
                f"{name.upper()}   {cs.fps:.1f} fps   {cs.track_state.value}   SNR(100) {snr}"
            )
        recording = st.recording.state == "recording"
        self.actions_by_key["record_start"].setEnabled(not recording)
        self.actions_by_key["record_stop"].setEnabled(recording)

    @staticmethod
    def _model_now(cs) -> tuple[str, float | None]:
        # What the model expects the console to read at the current range (computed on the
        # acquisition side, CameraStatus.model), else its first curve there.
        for name in (EXPECTED, "small_corrected"):
            if name in cs.model:
                return name, cs.model[name]
        return "", None

    def refresh_stops(self) -> None:
        rows = self.session.stops()
        self.stop_table.show_rows(rows)
        for plot in self.range_plots.values():
            plot.show_stops(rows)

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
        """Rebuild the model, hand it to the session, redraw; the refusal's message or None."""
        try:
            self.model = mc.applied_model(self.model, self.session, options)
        except (ValueError, OSError, KeyError) as exc:
            self.report(message := f"model options refused: {exc}")
            return message
        self.reload_curves()
        save_model_options(self.settings, options)
        self.report(f"model: {mc.describe(options)}")
        return None

    # ------------------------------------------------------------------ commands
    def report(self, message: str) -> None:
        """An operator-facing message (status bar, the message log, and the process's log: a
        recording's FILE.log keeps what the operator did and was told)."""
        log.info(message)
        self.messages.append(message)
        self.statusBar().showMessage(message, 10_000)

    def set_roi(self, camera: str, x: int, y: int) -> None:
        try:
            self.session.set_roi(camera, x, y)
        except ValueError as exc:
            self.report(str(exc))
            return
        self.report(f"{camera}: ROI set at column {x}, row {y}")

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

    def auto_levels(self) -> None:
        for panel in self.panels.values():
            panel.view.set_auto_levels(True)

    def reset_zoom(self) -> None:
        for panel in self.panels.values():
            panel.view.reset_zoom()

    def toggle_fullscreen(self) -> None:
        self.showNormal() if self.isFullScreen() else self.showFullScreen()

    def show_shortcuts(self) -> None:
        box = QMessageBox(
            QMessageBox.Icon.Information, "Keyboard shortcuts", shortcuts_text(), parent=self
        )
        box.setModal(False)
        box.open()

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
        if self.session.status().recording.state == "recording":
            self.session.stop_recording()
        self.save_settings()
        super().closeEvent(event)
        self.closed.emit()
