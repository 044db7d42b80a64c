"""One camera's panel in the console: the header (what the operator reads at arm's length), the
live image, and under it the box inset and the strip chart.

The panel places its three parts itself: the header as high as its tiles need at the panel's
width, the image no taller than that width lets it be (the height it could not use goes to
the strip chart), and the strip chart never lower than :data:`CHART_MIN_PX`; a box layout would
hand the image's share to whichever part asks for the most."""

from __future__ import annotations

from PySide6.QtCore import QRect, QSize
from PySide6.QtWidgets import QHBoxLayout, QWidget

from snrmon.gui import theme as th
from snrmon.gui.camera_header import CameraHeader
from snrmon.gui.camera_view import CameraView
from snrmon.gui.roi_inset import RoiInset
from snrmon.gui.strip_chart import StripChart

CHART_MIN_PX = 150  # the strip chart's height below which its axes crowd out its points
IMAGE_MIN_PX = 60
MIN_WIDTH_PX = 240
MARGIN_PX = 2
SPACING_PX = 4


class CameraPanel(QWidget):
    """Header, live image, box inset and strip chart of one camera."""

    def __init__(self, name: str, shape: tuple[int, int], config) -> None:
        super().__init__()
        self.name = name
        self.header = CameraHeader(name)
        self.header.setParent(self)
        self.view = CameraView(name, shape, config)
        self.view.setParent(self)
        self.inset = RoiInset(name, config.box_px)
        self.chart = StripChart(name)
        self.bottom = QWidget(self)
        row = QHBoxLayout(self.bottom)
        row.setContentsMargins(0, 0, 0, 0)
        row.setSpacing(SPACING_PX)
        row.addWidget(self.inset)
        row.addWidget(self.chart, 1)
        self._placed: tuple[int, int, int, int] | None = None

    def _bottom_min(self) -> int:
        inset = self.inset.minimumSizeHint().height() if self.inset.isVisibleTo(self) else 0
        return max(CHART_MIN_PX, inset)

    def minimumSizeHint(self) -> QSize:  # noqa: N802 (Qt's name)
        """At its present width (its header's height depends on it), at least 240 px."""
        width = max(self.width(), MIN_WIDTH_PX)
        header = self.header.layout().heightForWidth(width - 2 * MARGIN_PX)
        return QSize(
            MIN_WIDTH_PX,
            header + IMAGE_MIN_PX + self._bottom_min() + 2 * SPACING_PX + 2 * MARGIN_PX,
        )

    def sizeHint(self) -> QSize:  # noqa: N802 (Qt's name)
        return QSize(640, 720)

    def resizeEvent(self, event) -> None:  # noqa: N802 (Qt's name)
        super().resizeEvent(event)
        self.place()

    def place(self) -> None:
        """Lay the parts out for the panel's size (again only when something changed)."""
        w = self.width() - 2 * MARGIN_PX
        header_h = self.header.layout().heightForWidth(max(w, 1))
        bottom_min = self._bottom_min()
        key = (self.width(), self.height(), header_h, bottom_min)
        if key == self._placed:
            return
        self._placed = key
        rows, cols = self.view.shape
        levels = self.view.histogram.width()  # the levels control beside the image
        natural = int((w - levels) * rows / max(cols, 1)) + 2
        rest = self.height() - 2 * MARGIN_PX - header_h - 2 * SPACING_PX
        image_h = max(min(natural, rest - bottom_min), min(IMAGE_MIN_PX, rest))
        y = MARGIN_PX
        self.header.setGeometry(QRect(MARGIN_PX, y, w, header_h))
        y += header_h + SPACING_PX
        self.view.setGeometry(QRect(MARGIN_PX, y, w, image_h))
        y += image_h + SPACING_PX
        self.bottom.setGeometry(QRect(MARGIN_PX, y, w, max(self.height() - MARGIN_PX - y, 0)))
        self.updateGeometry()

    def show_insets(self, shown: bool) -> None:
        self.inset.setVisible(shown)
        self._placed = None
        self.place()

    def apply_theme(self, font_scale: float) -> None:
        """The current theme and ``font_scale`` on the header, inset and chart."""
        self.header.apply_theme(font_scale)
        self.inset.apply_theme(th.scaled_font(font_scale, 0.9))
        self.chart.apply_theme(th.scaled_font(font_scale))
        t = th.current()
        self.view.graphics.setBackground(t.background)
        axis = self.view.histogram.axis  # the levels' scale (DN) beside the image
        axis.setPen(t.text)
        axis.setTextPen(t.text)
        axis.setStyle(tickFont=th.scaled_font(font_scale, 0.9))
        self._placed = None
        self.place()
