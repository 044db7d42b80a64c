"""The enlarged box around the measured peak with its pixel values, like the paper's Fig. 5.

Each cell is one pixel of the displayed frame, shaded between the box's own minimum and maximum,
with its value in DN; the rim pixels (the background of Eq. 4) are outlined, the peak is marked.
Below, the session's numbers for its last measured frame: peak, background mean and std, SNR.
The inset cuts pixels out of the frame; it computes no statistic.
"""

from __future__ import annotations

import numpy as np
from PySide6.QtCore import QRectF, Qt
from PySide6.QtGui import QColor, QFont, QImage, QPainter, QPalette, QPen
from PySide6.QtWidgets import QLabel, QSizePolicy, QVBoxLayout, QWidget

from snrmon.acquisition.engine.status import CameraStatus
from snrmon.gui import theme as th


def box_pixels(pixels: np.ndarray, cx: int, cy: int, box_px: int) -> np.ndarray:
    """The ``box_px`` square of ``pixels`` centred on column ``cx``, row ``cy`` as float, NaN
    where it leaves the image."""
    half = box_px // 2
    out = np.full((box_px, box_px), np.nan)
    h, w = pixels.shape
    r0, c0 = cy - half, cx - half
    rs, re = max(r0, 0), min(r0 + box_px, h)
    cs, ce = max(c0, 0), min(c0 + box_px, w)
    if rs < re and cs < ce:
        out[rs - r0 : re - r0, cs - c0 : ce - c0] = pixels[rs:re, cs:ce]
    return out


# The widest lines the numbers take (the inset is made this wide, so none is cut).
NUMBERS_TEMPLATE = (
    "peak (8888, 8888) 88888 DN\n"
    "extent_rim mean 88888.8 DN\n"
    "std 888.88 DN   SNR 8888.88\n"
    "flags: rim_contaminated"
)


def inset_text(last) -> str:
    """The numbers under the grid: the last measured frame's peak, background and SNR."""
    flags = ",\n".join(sorted(last.flags)) or "none"  # a flag a line: the inset stays narrow
    return (
        f"peak ({last.peak_x}, {last.peak_y}) {last.peak:.0f} DN\n"
        f"{last.background} mean {last.bg_mean:.1f} DN\n"
        f"std {last.bg_std:.2f} DN   SNR {last.snr:.2f}\n"
        f"flags: {flags}"
    )


class _BoxGrid(QWidget):
    def __init__(self) -> None:
        super().__init__()
        self.values: np.ndarray | None = None
        self.digits_px: int | None = None  # the values' text size as last painted (None: none)
        self.setMinimumSize(150, 150)
        self.setSizePolicy(QSizePolicy.Policy.Expanding, QSizePolicy.Policy.Expanding)

    def set_values(self, values: np.ndarray | None) -> None:
        self.values = values
        self.update()

    def paintEvent(self, _event) -> None:  # noqa: N802 (Qt's name)
        p = QPainter(self)
        p.fillRect(self.rect(), self.palette().color(QPalette.ColorRole.Base))
        v = self.values
        if v is None:
            p.setPen(self.palette().color(QPalette.ColorRole.PlaceholderText))
            p.drawText(self.rect(), Qt.AlignmentFlag.AlignCenter, "click the drone\nto set the ROI")
            return
        n = v.shape[0]
        side = min(self.width(), self.height())
        cell = side / n
        x0 = (self.width() - side) / 2
        y0 = (self.height() - side) / 2
        finite = v[np.isfinite(v)]
        lo, hi = (float(finite.min()), float(finite.max())) if finite.size else (0.0, 1.0)
        span = hi - lo if hi > lo else 1.0
        font = QFont()
        font.setPixelSize(max(th.MIN_TEXT_PX, int(cell * 0.28)))
        p.setFont(font)
        # The values only where they fit their cells at a legible size (the shading and the
        # numbers under the grid say the rest): a wider inset, or I for more room, shows them.
        widest = p.fontMetrics().horizontalAdvance(f"{hi:.0f}")
        self.digits_px = font.pixelSize() if widest <= cell - 2 else None
        # The shading as one image scaled up, the numbers a pen at a time: each Qt call lets
        # the busy measuring threads take the interpreter lock, and a cell a call made the
        # paint 0.5 ms alone and 6.5 ms beside a thread running Python.
        grey = np.zeros(v.shape, np.uint32)
        ok = np.isfinite(v)
        levels = (40 + 200 * (np.where(ok, v, lo) - lo) / span).astype(np.uint32)
        grey[ok] = levels[ok] * 0x010101
        grey |= np.uint32(0xFF000000)
        shades = QImage(grey.data, n, n, 4 * n, QImage.Format.Format_RGB32)
        p.drawImage(QRectF(x0, y0, side, side), shades)
        for colour, dark in (("#000000", False), ("#ffffff", True)):
            if self.digits_px is None:
                break
            p.setPen(QColor(colour))
            for r, c in zip(*np.nonzero(ok & ((levels <= 140) == dark)), strict=True):
                rect = QRectF(x0 + c * cell, y0 + r * cell, cell, cell)
                p.drawText(rect, Qt.AlignmentFlag.AlignCenter, f"{v[r, c]:.0f}")
        rim_pen = QPen(QColor("#ffd34d"), 2)
        p.setPen(rim_pen)
        p.setBrush(Qt.BrushStyle.NoBrush)
        p.drawRect(QRectF(x0 + 1, y0 + 1, side - 2, side - 2))
        p.drawRect(QRectF(x0 + cell, y0 + cell, side - 2 * cell, side - 2 * cell))
        p.setPen(QPen(QColor("#ff4040"), 2))
        mid = n // 2
        p.drawRect(QRectF(x0 + mid * cell, y0 + mid * cell, cell, cell))


class RoiInset(QWidget):
    """The box around the last measured peak of one camera, enlarged, with values."""

    def __init__(self, camera: str, box_px: int, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.camera = camera
        self.box_px = box_px
        self.grid = _BoxGrid()
        self.numbers = QLabel("")
        self.numbers.setTextFormat(Qt.TextFormat.PlainText)
        self.numbers.setAlignment(Qt.AlignmentFlag.AlignLeft | Qt.AlignmentFlag.AlignTop)
        self.apply_theme()
        self.setToolTip(
            f"{camera}: the {box_px}x{box_px} box centred on the measured peak (pixel values in "
            f"DN of the displayed frame). Outlined band = the {4 * (box_px - 1)} rim pixels, the "
            "background of Eq. 4 while the drone fits the box (a wider drone is measured against "
            "the rim of its extent, 'extent_rim'; docs/measurement.md); red = the peak."
        )
        lay = QVBoxLayout(self)
        lay.setContentsMargins(2, 2, 2, 2)
        lay.addWidget(self.grid, 1)
        lay.addWidget(self.numbers)

    def apply_theme(self, font: QFont | None = None) -> None:
        """The numbers in ``font``; as wide as their longest line (never cut), at least as wide
        as the grid's minimum."""
        if font is not None:
            self.numbers.setFont(font)
        metrics = self.numbers.fontMetrics()
        wide = max(metrics.horizontalAdvance(line) for line in NUMBERS_TEMPLATE.splitlines())
        self.setFixedWidth(max(self.grid.minimumWidth(), wide) + 12)
        self.grid.update()

    def show_box(self, pixels: np.ndarray | None, status: CameraStatus) -> None:
        """Cut the box around the last measured peak out of ``pixels`` and show the numbers."""
        last = status.last.result if status.last is not None else None
        if pixels is None or last is None or status.roi_xy is None:
            self.grid.set_values(None)
            self.numbers.setText("no measurement")
            return
        self.grid.set_values(box_pixels(pixels, last.peak_x, last.peak_y, self.box_px))
        self.numbers.setText(inset_text(last))
