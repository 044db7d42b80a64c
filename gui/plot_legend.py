"""A plot's legend as Qt widgets beside the plot, never over its data: one entry per item, a
sample of its pen or symbol and its name in words, wrapped onto as many lines as the width
needs (:class:`snrmon.gui.flow_layout.FlowLayout`). A checkable entry shows or hides its items
(e.g. a model curve's uncertainty band); the whole legend can be folded away."""

from __future__ import annotations

import math

from PySide6.QtCore import QPointF, QSize, Qt, Signal
from PySide6.QtGui import QBrush, QColor, QIcon, QPainter, QPen, QPixmap, QPolygonF
from PySide6.QtWidgets import QCheckBox, QLabel, QWidget

from snrmon.gui.flow_layout import FlowBox

SAMPLE_W, SAMPLE_H = 30, 14


def sample_icon(
    colour: str,
    *,
    kind: str = "line",
    dashed: bool = False,
    width: float = 2.0,
    fill: str | None = None,
) -> QIcon:
    """A small picture of how an item is drawn: a line (``dashed``), a band (``fill``), a
    marker ("square", "star", "dot") or a marker with an error bar ("bar")."""
    pix = QPixmap(SAMPLE_W, SAMPLE_H)
    pix.fill(Qt.GlobalColor.transparent)
    p = QPainter(pix)
    p.setRenderHint(QPainter.RenderHint.Antialiasing)
    pen = QPen(QColor(colour), width)
    pen.setStyle(Qt.PenStyle.DashLine if dashed else Qt.PenStyle.SolidLine)
    mid = SAMPLE_H / 2
    if kind == "band":
        c = QColor(fill or colour)
        c.setAlpha(90)
        p.fillRect(1, 2, SAMPLE_W - 2, SAMPLE_H - 4, c)
        p.setPen(QPen(QColor(colour), 1))
        p.drawLine(1, 2, SAMPLE_W - 1, 2)
        p.drawLine(1, SAMPLE_H - 2, SAMPLE_W - 1, SAMPLE_H - 2)
    elif kind in ("square", "bar"):
        if kind == "bar":
            p.setPen(QPen(QColor(colour), 1.5))
            p.drawLine(QPointF(SAMPLE_W / 2, 0), QPointF(SAMPLE_W / 2, SAMPLE_H))
        p.setPen(QPen(QColor("#000000"), 1))
        p.setBrush(QBrush(QColor(colour)))
        p.drawRect(int(SAMPLE_W / 2 - 4), int(mid - 4), 8, 8)
    elif kind == "star":
        p.setPen(QPen(QColor(colour), 1))
        p.setBrush(QBrush(QColor(colour)))
        pts = []
        for i in range(10):
            r = 6.5 if i % 2 == 0 else 2.8
            a = -math.pi / 2 + i * math.pi / 5
            pts.append(QPointF(SAMPLE_W / 2 + r * math.cos(a), mid + r * math.sin(a)))
        p.drawPolygon(QPolygonF(pts))
    elif kind == "dot":
        p.setPen(Qt.PenStyle.NoPen)
        p.setBrush(QBrush(QColor(colour)))
        p.drawEllipse(QPointF(SAMPLE_W / 2, mid), 2.5, 2.5)
    else:
        p.setPen(pen)
        p.drawLine(QPointF(1, mid), QPointF(SAMPLE_W - 1, mid))
    p.end()
    return QIcon(pix)


class PlotLegend(FlowBox):
    """The entries of one plot, wrapped by width; ``toggled(key, shown)`` when a checkable
    entry is switched by the operator."""

    toggled = Signal(str, bool)

    def __init__(self, parent: QWidget | None = None, *, spacing: int = 10) -> None:
        super().__init__(parent, spacing=spacing)
        self.entries: dict[str, QCheckBox] = {}
        self._layout = self.flow
        self.setObjectName("plot_legend")

    def clear(self) -> None:
        for box in self.entries.values():
            self._layout.removeWidget(box)
            box.deleteLater()
        self.entries = {}

    def add(
        self,
        key: str,
        text: str,
        icon: QIcon,
        *,
        checkable: bool = False,
        shown: bool = True,
        tip: str = "",
    ) -> QCheckBox:
        """An entry ``text`` with ``icon``; a checkable one starts ``shown`` or not."""
        box = QCheckBox(text)
        box.setIcon(icon)
        box.setIconSize(QSize(SAMPLE_W, SAMPLE_H))
        box.setFocusPolicy(Qt.FocusPolicy.NoFocus)  # the keys belong to the shortcuts
        if checkable:
            box.setChecked(shown)
            box.toggled.connect(lambda on, k=key: self.toggled.emit(k, on))
        else:
            # Not a switch: no check box, only the sample and the words.
            box.setStyleSheet("QCheckBox::indicator { width: 0px; height: 0px; }")
            box.setAttribute(Qt.WidgetAttribute.WA_TransparentForMouseEvents)
        if tip:
            box.setToolTip(tip)
        self.entries[key] = box
        self._layout.addWidget(box)
        self.fit_height()
        return box

    def set_text(self, key: str, text: str) -> None:
        box = self.entries.get(key)
        if box is not None and box.text() != text:
            box.setText(text)
            self.fit_height()

    def texts(self) -> list[str]:
        """The entries' words, in order (tests, the status file)."""
        return [box.text() for box in self.entries.values()]


def caption(text: str, tip: str = "") -> QLabel:
    """A one-line label for a plot's bar (its title, what the curves were computed at)."""
    label = QLabel(text)
    label.setTextFormat(Qt.TextFormat.PlainText)
    if tip:
        label.setToolTip(tip)
    return label
