"""The console's two themes, dark (a lab, a night) and daylight (a laptop in the sun: white
background, black text, saturated dark colours), its font scale, and pyqtgraph's options.

One :class:`Theme` holds every colour the console draws with: the Qt palette, the plots'
background and axes, each model curve's pen (by curve name, so a curve keeps its colour and
style in every plot and theme), the cameras' stop markers and the colours of the measured/model
agreement. :func:`apply_theme` sets the application's palette and font; each chart restyles its
own items through its ``apply_theme`` (the main window calls them on a switch).

pyqtgraph is told once, before any image item exists, that images are row-major (``pixels[row,
column]``), so that image x is the column and image y the row, as in the measurement.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor, QFont, QFontInfo, QPalette
from PySide6.QtWidgets import QApplication

ALARM = "#d9352b"
RECOVERED = "#2e8b57"
FONT_SCALES = (0.8, 0.9, 1.0, 1.1, 1.25, 1.4, 1.6, 1.8, 2.0)
MIN_TEXT_PX = 11  # no text of the console smaller, at any font scale or screen density
BASE_POINT_SIZE = 10.0  # the console's text at font scale 1 (pt); headers and plots scale with it


@dataclass(frozen=True)
class CurveStyle:
    """How one model curve is drawn: colour, dashed (uncorrected) or solid, width (px)."""

    colour: str
    dashed: bool = False
    width: float = 2.0


@dataclass(frozen=True)
class Theme:
    name: str
    background: str  # plots and editable fields
    panel: str  # windows, docks, buttons
    text: str
    muted: str  # secondary text: captions, disabled items
    accent: str
    grid_alpha: float
    snr: str  # the strip chart's per-frame points
    mean: str  # the strip chart's running mean and its band
    live: str  # the range plot's live point
    model_line: str  # the strip chart's model reading
    curves: dict[str, CurveStyle] = field(default_factory=dict)
    spare: tuple[str, ...] = ()  # curves not named in ``curves`` take these in turn
    cameras: dict[str, str] = field(default_factory=dict)
    verdicts: dict[str, tuple[str, str]] = field(default_factory=dict)  # (fill, text)

    def curve_style(self, name: str, index: int = 0) -> CurveStyle:
        """The pen of model curve ``name`` (a sky variant, ``"<name> @ sky <T> K"``, is drawn
        like ``name``); a curve the theme does not name takes a spare colour by ``index``."""
        base = name.split(" @ ")[0]
        if base in self.curves:
            return self.curves[base]
        for prefix, style in self.curves.items():
            if prefix.endswith("*") and base.startswith(prefix[:-1]):
                return style
        return CurveStyle(self.spare[index % len(self.spare)], dashed=True, width=1.5)

    def camera_colour(self, camera: str) -> str:
        return self.cameras.get(camera, self.accent)


DARK = Theme(
    name="dark",
    background="#1e1f22",
    panel="#2b2d31",
    text="#e6e7ea",
    muted="#a4a6aa",
    accent="#4aa3ff",
    grid_alpha=0.25,
    snr="#8fd3ff",
    mean="#ffd34d",
    live="#ffffff",
    model_line="#ff7f50",
    curves={
        "small": CurveStyle("#ff8c5a", dashed=True),
        "large": CurveStyle("#7ee07e", dashed=True),
        "small_corrected": CurveStyle("#ff8c5a"),
        "large_corrected": CurveStyle("#7ee07e"),
        "expected_eq4*": CurveStyle("#ffffff", width=3.0),
        "paper_*": CurveStyle("#9a9ca0", dashed=True, width=1.5),
    },
    spare=("#ff66cc", "#66ffff", "#cccc66"),
    cameras={"mwir": "#ffb347", "lwir": "#7ec8ff"},
    verdicts={
        "inside": ("#3ecf6e", "#000000"),
        "near": ("#ffc233", "#000000"),
        "outside": ("#ff5a4f", "#000000"),
    },
)

DAYLIGHT = Theme(
    name="daylight",
    background="#ffffff",
    panel="#eeeeee",
    text="#000000",
    muted="#333333",
    accent="#0046a6",
    grid_alpha=0.35,
    snr="#0069c0",
    mean="#8a5a00",
    live="#000000",
    model_line="#c02800",
    curves={
        "small": CurveStyle("#c02800", dashed=True),
        "large": CurveStyle("#006b1a", dashed=True),
        "small_corrected": CurveStyle("#c02800"),
        "large_corrected": CurveStyle("#006b1a"),
        "expected_eq4*": CurveStyle("#000000", width=3.0),
        "paper_*": CurveStyle("#555555", dashed=True, width=1.5),
    },
    spare=("#a0007a", "#006f8a", "#6b6b00"),
    cameras={"mwir": "#c45a00", "lwir": "#0050c0"},
    verdicts={
        "inside": ("#007a2e", "#ffffff"),
        "near": ("#8a5d00", "#ffffff"),
        "outside": ("#c0150c", "#ffffff"),
    },
)

THEMES = {t.name: t for t in (DARK, DAYLIGHT)}
_current = [DARK]


def current() -> Theme:
    """The theme in force (the dark one until :func:`apply_theme` says otherwise)."""
    return _current[0]


def theme_named(name: str) -> Theme:
    """The theme called ``name`` (dark, daylight); a ValueError naming the known ones."""
    try:
        return THEMES[name]
    except KeyError:
        raise ValueError(f"unknown theme {name!r} (known: {', '.join(THEMES)})") from None


def check_font_scale(scale: float) -> float:
    """``scale`` if it is one the console offers (0.8 to 2), else a ValueError naming it."""
    if not FONT_SCALES[0] <= scale <= FONT_SCALES[-1]:
        raise ValueError(f"font scale must be {FONT_SCALES[0]} to {FONT_SCALES[-1]}, got {scale}")
    return float(scale)


def legible(font: QFont) -> QFont:
    """``font``, at least :data:`MIN_TEXT_PX` pixels high on this screen (a point size is
    pixels only through the screen's dots per inch: 9 pt is 12 px at 96 dpi, 9 px at 72)."""
    if QFontInfo(font).pixelSize() < MIN_TEXT_PX:
        font.setPixelSize(MIN_TEXT_PX)
    return font


def scaled_font(scale: float, factor: float = 1.0, *, bold: bool = False) -> QFont:
    """The application's font at ``scale`` times ``factor`` (e.g. 1.6 for a header value),
    never under :data:`MIN_TEXT_PX`."""
    font = QFont(QApplication.font())
    font.setPointSizeF(BASE_POINT_SIZE * scale * factor)
    font.setBold(bold)
    return legible(font)


def configure_pyqtgraph() -> None:
    """Row-major images and the current theme's plot colours; call before any pyqtgraph item
    is built."""
    t = current()
    pg.setConfigOptions(
        imageAxisOrder="row-major", background=t.background, foreground=t.text, antialias=False
    )


def apply_theme(app: QApplication, theme: Theme, font_scale: float = 1.0) -> None:
    """Fusion style, ``theme``'s palette (readable tooltips, disabled items still legible) and
    the application font at ``font_scale``; plots made after this take the theme's colours."""
    _current[0] = theme
    configure_pyqtgraph()
    app.setStyle("Fusion")
    pal = QPalette()
    roles = {
        QPalette.ColorRole.Window: theme.panel,
        QPalette.ColorRole.WindowText: theme.text,
        QPalette.ColorRole.Base: theme.background,
        QPalette.ColorRole.AlternateBase: theme.panel,
        QPalette.ColorRole.ToolTipBase: "#ffffe0",
        QPalette.ColorRole.ToolTipText: "#000000",
        QPalette.ColorRole.Text: theme.text,
        QPalette.ColorRole.Button: theme.panel,
        QPalette.ColorRole.ButtonText: theme.text,
        QPalette.ColorRole.BrightText: ALARM,
        QPalette.ColorRole.Highlight: theme.accent,
        QPalette.ColorRole.HighlightedText: "#ffffff" if theme is DAYLIGHT else "#000000",
        QPalette.ColorRole.Link: theme.accent,
        QPalette.ColorRole.PlaceholderText: theme.muted,
    }
    for role, colour in roles.items():
        pal.setColor(role, QColor(colour))
    for role in (
        QPalette.ColorRole.Text,
        QPalette.ColorRole.ButtonText,
        QPalette.ColorRole.WindowText,
    ):
        pal.setColor(QPalette.ColorGroup.Disabled, role, QColor(theme.muted))
    app.setPalette(pal)
    font = QFont(app.font())
    font.setPointSizeF(BASE_POINT_SIZE * font_scale)
    app.setFont(legible(font))


def apply_dark_theme(app: QApplication) -> None:
    """The dark theme at font scale 1 (the console's default)."""
    apply_theme(app, DARK)


def pen(style: CurveStyle, alpha: int = 255):
    """A pyqtgraph pen for ``style`` (dashed for an uncorrected curve)."""
    colour = QColor(style.colour)
    colour.setAlpha(alpha)
    return pg.mkPen(
        colour,
        width=style.width,
        style=Qt.PenStyle.DashLine if style.dashed else Qt.PenStyle.SolidLine,
    )


def style_plot(plot: pg.PlotWidget, font: QFont) -> None:
    """The current theme's background, axes and grid on ``plot``, and ``font`` for its tick
    labels and axis titles."""
    t = current()
    plot.setBackground(t.background)
    item = plot.getPlotItem()
    for name in ("left", "bottom", "right", "top"):
        axis = item.getAxis(name)
        axis.setPen(pg.mkPen(t.text))
        axis.setStyle(tickFont=font)
        axis.label.setFont(font)
        axis.setTextPen(pg.mkPen(t.text))  # re-typesets the title in its new font and colour
        if axis.grid is not False:
            axis.setGrid(int(255 * t.grid_alpha))
