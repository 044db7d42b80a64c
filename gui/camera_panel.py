"""One camera's panel in the console (header, live image, box inset, strip chart) and the
model's value at the current range read off a curve the model computed."""

from __future__ import annotations

import math

import numpy as np
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


def model_at_range(curve: tuple, range_m: float | None) -> float | None:
    """A model curve's value at ``range_m``, read off the curve the model computed (linear
    between its samples; None outside its range, never extrapolated)."""
    if range_m is None or not math.isfinite(range_m) or len(curve) != 2:
        return None
    r, s = np.asarray(curve[0], float), np.asarray(curve[1], float)
    if r.size == 0 or not (r.min() <= range_m <= r.max()):
        return None
    order = np.argsort(r)
    return float(np.interp(range_m, r[order], s[order]))
