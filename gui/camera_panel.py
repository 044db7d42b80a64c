"""One camera's panel in the console (header, live image, box inset, strip chart) and the
model's value at the current range read off a curve the model computed."""

from __future__ import annotations

from PySide6.QtWidgets import QHBoxLayout, QLabel, QVBoxLayout, QWidget

from snrmon.gui.camera_view import CameraView
from snrmon.gui.roi_inset import RoiInset
from snrmon.gui.strip_chart import StripChart


class CameraPanel(QWidget):
    """Header, live image, box inset and strip chart of one camera."""

    def __init__(self, name: str, shape: tuple[int, int], config) -> None:
        super().__init__()
        self.name = name
        self.header = QLabel(name.upper())
        self.header.setStyleSheet("font-weight: bold;")
        self.view = CameraView(name, shape, config)
        self.inset = RoiInset(name, config.box_px)
        self.inset.setFixedWidth(220)
        self.chart = StripChart(name)
        bottom = QHBoxLayout()
        bottom.addWidget(self.inset)
        bottom.addWidget(self.chart, 1)
        lay = QVBoxLayout(self)
        lay.setContentsMargins(2, 2, 2, 2)
        lay.addWidget(self.header)
        lay.addWidget(self.view, 3)
        lay.addLayout(bottom, 2)
