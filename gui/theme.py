"""The console's dark theme (a field laptop in daylight or at night) and pyqtgraph's options.

pyqtgraph is told once, before any image item exists, that images are row-major (``pixels[row,
column]``), so that image x is the column and image y the row, as in the measurement.
"""

from __future__ import annotations

import pyqtgraph as pg
from PySide6.QtGui import QColor, QPalette
from PySide6.QtWidgets import QApplication

BACKGROUND = "#1e1f22"
PANEL = "#2b2d31"
TEXT = "#dcdde0"
ACCENT = "#4aa3ff"
ALARM = "#d9352b"
RECOVERED = "#2e8b57"
SNR_COLOR = "#8fd3ff"
MEAN_COLOR = "#ffd34d"
MODEL_COLORS = ("#ff7f50", "#7fff7f", "#ff66cc", "#66ffff", "#cccccc")
CAMERA_COLORS = {"mwir": "#ffb347", "lwir": "#7ec8ff"}


def configure_pyqtgraph() -> None:
    """Row-major images, dark plot background; call before any pyqtgraph item is built."""
    pg.setConfigOptions(
        imageAxisOrder="row-major", background=BACKGROUND, foreground=TEXT, antialias=False
    )


def apply_dark_theme(app: QApplication) -> None:
    """Fusion style with a dark palette (readable tooltips, disabled items still legible)."""
    app.setStyle("Fusion")
    pal = QPalette()
    roles = {
        QPalette.ColorRole.Window: PANEL,
        QPalette.ColorRole.WindowText: TEXT,
        QPalette.ColorRole.Base: BACKGROUND,
        QPalette.ColorRole.AlternateBase: PANEL,
        QPalette.ColorRole.ToolTipBase: "#ffffe0",
        QPalette.ColorRole.ToolTipText: "#000000",
        QPalette.ColorRole.Text: TEXT,
        QPalette.ColorRole.Button: PANEL,
        QPalette.ColorRole.ButtonText: TEXT,
        QPalette.ColorRole.BrightText: "#ff5555",
        QPalette.ColorRole.Highlight: ACCENT,
        QPalette.ColorRole.HighlightedText: "#000000",
        QPalette.ColorRole.Link: ACCENT,
    }
    for role, colour in roles.items():
        pal.setColor(role, QColor(colour))
    for role in (QPalette.ColorRole.Text, QPalette.ColorRole.ButtonText):
        pal.setColor(QPalette.ColorGroup.Disabled, role, QColor("#7a7c80"))
    app.setPalette(pal)
