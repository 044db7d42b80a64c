"""Every operator action as a QAction with its shortcut and tooltip, and the menus they live in.

One table (:data:`ACTIONS`) is the single source for the menus, the shortcuts and docs/console.md.
"""

from __future__ import annotations

from dataclasses import dataclass

from PySide6.QtCore import QRect
from PySide6.QtGui import QAction, QKeySequence
from PySide6.QtWidgets import (
    QApplication,
    QDialog,
    QDialogButtonBox,
    QMainWindow,
    QMenuBar,
    QPlainTextEdit,
    QVBoxLayout,
    QWidget,
)


@dataclass(frozen=True)
class ActionSpec:
    key: str
    text: str
    shortcut: str
    tip: str
    menu: str
    slot: str  # the window's method called with no argument
    replay: bool = False  # only in replay mode


ACTIONS: tuple[ActionSpec, ...] = (
    ActionSpec(
        "record_start",
        "Start &recording...",
        "Ctrl+R",
        "Record everything from now into a new HDF5 session file",
        "&Session",
        "start_recording",
    ),
    ActionSpec(
        "record_stop",
        "S&top recording",
        "Ctrl+Shift+R",
        "Finish the session file (it stays readable even after a crash)",
        "&Session",
        "stop_recording",
    ),
    ActionSpec(
        "mark_stop",
        "&Mark stop",
        "M",
        "The drone is hovering at a stop now: start a stop-table row",
        "&Session",
        "mark_stop",
    ),
    ActionSpec(
        "event",
        "Mark &event",
        "E",
        "Put a timestamped 'event' note into the record now (no dialog)",
        "&Session",
        "mark_event",
    ),
    ActionSpec(
        "note",
        "Add &note...",
        "N",
        "Write a timestamped note into the record",
        "&Session",
        "add_note",
    ),
    ActionSpec(
        "reference",
        "Capture &background reference",
        "B",
        "Average the next 64 frames of every camera (clear sky, no drone in view) into "
        "the fixed-pattern reference removed before Eq. 4; the raw SNR stays shown",
        "&Session",
        "capture_reference",
    ),
    ActionSpec(
        "copy_stops",
        "&Copy stop table as CSV",
        "Ctrl+Shift+C",
        "The stop table's selected rows (or all) as the report's CSV, on the clipboard",
        "&Session",
        "copy_stops",
    ),
    ActionSpec(
        "screenshot",
        "Save &screenshot...",
        "Ctrl+Shift+S",
        "Save the whole window as a PNG",
        "&Session",
        "save_screenshot",
    ),
    ActionSpec(
        "quit",
        "&Quit",
        "Ctrl+Q",
        "Close the console (recording is finished first)",
        "&Session",
        "close",
    ),
    ActionSpec(
        "switch_camera",
        "S&witch camera",
        "C",
        "Make the next camera the active one (outlined): the track keys act on it and the "
        "SNR-versus-range plot shows it",
        "&Track",
        "switch_camera",
    ),
    ActionSpec(
        "reselect",
        "&Re-select track",
        "T",
        "Set the active camera's ROI again where the drone is: at its GPS position projected "
        "into the camera, else at the last measured peak",
        "&Track",
        "reselect_track",
    ),
    ActionSpec(
        "release",
        "Re&lease track",
        "Esc",
        "Stop measuring on the active camera (until the next click)",
        "&Track",
        "release_track",
    ),
    ActionSpec(
        "palette",
        "Next &palette",
        "G",
        "The images' palette: grey, white-hot, black-hot, ironbow, in turn",
        "&View",
        "next_palette",
    ),
    ActionSpec(
        "enlarge_range",
        "&Large SNR-versus-range plot",
        "P",
        "The SNR-versus-range plot takes the images' place; again to bring the images back",
        "&View",
        "toggle_range_large",
    ),
    ActionSpec(
        "enlarge_stops",
        "Large &stop table",
        "S",
        "The stop table takes the images' place (every stop in view on a laptop's screen); "
        "again to bring the images back",
        "&View",
        "toggle_stops_large",
    ),
    ActionSpec(
        "insets",
        "Box &insets",
        "I",
        "Show or hide the box insets under the images (hidden at first where the panels are "
        "too narrow for them beside the strip charts)",
        "&View",
        "toggle_insets",
    ),
    ActionSpec(
        "daylight",
        "&Daylight theme",
        "Ctrl+D",
        "Light background, high contrast (for a screen in the sun); again for the dark theme",
        "&View",
        "toggle_daylight",
    ),
    ActionSpec(
        "font_larger",
        "&Larger text",
        "Ctrl+=",
        "Scale every text of the console up (headers, tables, plots)",
        "&View",
        "font_larger",
    ),
    ActionSpec(
        "font_smaller",
        "S&maller text",
        "Ctrl+-",
        "Scale every text of the console down",
        "&View",
        "font_smaller",
    ),
    ActionSpec(
        "font_reset",
        "Text at normal si&ze",
        "Ctrl+0",
        "Font scale 1",
        "&View",
        "font_reset",
    ),
    ActionSpec(
        "auto_levels",
        "&Auto levels",
        "A",
        "Robust display levels (0.5 / 99.9 percentiles, DN) on every camera",
        "&View",
        "auto_levels",
    ),
    ActionSpec(
        "reset_zoom", "Reset &zoom", "Z", "Show each whole image again", "&View", "reset_zoom"
    ),
    ActionSpec(
        "reload_model",
        "Reload model &curves",
        "Ctrl+L",
        "Ask the model for the SNR-versus-range curves again",
        "&View",
        "reload_curves",
    ),
    ActionSpec(
        "model_options",
        "Model &options...",
        "Ctrl+M",
        "Target preset, curves shown (small/large, uncorrected/corrected) and the "
        "model's background temperature (K)",
        "&View",
        "model_options",
    ),
    ActionSpec(
        "noise_panel",
        "&Noise panel",
        "Ctrl+Shift+N",
        "Show or hide total, temporal and spatial noise (DN) per camera",
        "&View",
        "toggle_noise_panel",
    ),
    ActionSpec(
        "fullscreen", "&Full screen", "F11", "Toggle full screen", "&View", "toggle_fullscreen"
    ),
    ActionSpec(
        "replay_play",
        "&Play / pause",
        "Space",
        "Play the recording at the chosen speed (x real time), or pause it",
        "&Replay",
        "replay_toggle",
        True,
    ),
    ActionSpec(
        "replay_step",
        "&Step one frame",
        "Right",
        "Show and measure the next recorded frame (pauses)",
        "&Replay",
        "replay_step",
        True,
    ),
    ActionSpec(
        "replay_back",
        "Step &back one frame",
        "Left",
        "Seek to the previous recorded frame (the measurement restarts there)",
        "&Replay",
        "replay_back",
        True,
    ),
    ActionSpec(
        "replay_home",
        "Go to s&tart",
        "Home",
        "Seek to the first recorded frame",
        "&Replay",
        "replay_home",
        True,
    ),
    ActionSpec(
        "replay_faster",
        "&Faster",
        "]",
        "Next replay speed up (x real time)",
        "&Replay",
        "replay_faster",
        True,
    ),
    ActionSpec(
        "replay_slower",
        "S&lower",
        "[",
        "Next replay speed down (x real time)",
        "&Replay",
        "replay_slower",
        True,
    ),
    ActionSpec(
        "shortcuts",
        "&Keyboard shortcuts",
        "F1",
        "List every action and its key",
        "&Help",
        "show_shortcuts",
    ),
)


def install_actions(
    window: QMainWindow, menubar: QMenuBar, *, replay: bool = False
) -> dict[str, QAction]:
    """Create the actions, connect each to ``window.<slot>()``, put them in menus; the
    replay actions only when ``replay``."""
    menus: dict[str, object] = {}
    actions: dict[str, QAction] = {}
    for spec in ACTIONS:
        if spec.replay and not replay:
            continue
        action = QAction(spec.text, window)
        action.setShortcut(QKeySequence(spec.shortcut))
        action.setToolTip(f"{spec.tip} ({spec.shortcut})")
        action.setStatusTip(spec.tip)
        slot = getattr(window, spec.slot)
        action.triggered.connect(lambda _checked=False, s=slot: s())
        if spec.menu not in menus:
            menus[spec.menu] = menubar.addMenu(spec.menu)
        menus[spec.menu].addAction(action)
        window.addAction(action)  # shortcuts work even with the menu bar hidden
        actions[spec.key] = action
    return actions


def shortcuts_text() -> str:
    """Every action and its key, one per line."""
    return "\n".join(f"{s.shortcut:<14} {s.text.replace('&', '')}: {s.tip}" for s in ACTIONS)


class ShortcutsDialog(QDialog):
    """The list of :func:`shortcuts_text` in a scrolling box, never taller than the screen it
    opens on (its OK button always on it: at 1366 x 768 the list is taller than the screen)."""

    def __init__(self, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.setWindowTitle("Keyboard shortcuts")
        self.text = QPlainTextEdit(shortcuts_text())
        self.text.setReadOnly(True)
        self.text.setLineWrapMode(QPlainTextEdit.LineWrapMode.NoWrap)
        self.buttons = QDialogButtonBox(QDialogButtonBox.StandardButton.Ok)
        self.buttons.accepted.connect(self.accept)
        lay = QVBoxLayout(self)
        lay.addWidget(self.text, 1)
        lay.addWidget(self.buttons)
        screen = (parent.screen() if parent is not None else None) or QApplication.primaryScreen()
        room = screen.availableGeometry() if screen is not None else QRect(0, 0, 1366, 768)
        metrics = self.text.fontMetrics()
        lines = shortcuts_text().splitlines()
        want_w = max(metrics.horizontalAdvance(line) for line in lines) + 48
        want_h = metrics.lineSpacing() * len(lines) + 100
        self.resize(min(want_w, int(room.width() * 0.9)), min(want_h, int(room.height() * 0.85)))
        self.move(room.center() - self.rect().center())
