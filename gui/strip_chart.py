"""One camera's strip chart: per-frame peak SNR (Eq. 4), its 100-frame running mean with a
+/- one std band, and the model's prediction at the current range as a horizontal line.

Every number is the session's (:meth:`acquisition.camera_pipeline.CameraPipeline.series`, rows of
t_host_ns, snr, running mean, running std, range_m); the chart only converts times to seconds
before now and adds mean +/- std for the band's edges.
"""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QVBoxLayout, QWidget

from gui.theme import MEAN_COLOR, MODEL_COLORS, SNR_COLOR

WINDOW_S = 30.0


class StripChart(QWidget):
    """Peak SNR versus time (seconds before now) for one camera."""

    def __init__(self, camera: str, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.camera = camera
        self.points_drawn = 0
        self.plot = pg.PlotWidget()
        self.plot.setLabel("left", "peak SNR")
        self.plot.setLabel("bottom", "time before now", units="s")
        self.plot.showGrid(x=True, y=True, alpha=0.25)
        self.plot.setXRange(-WINDOW_S, 0.0, padding=0.0)
        self.plot.addLegend(offset=(5, 5), labelTextSize="8pt")
        self.snr_curve = self.plot.plot(
            pen=None, symbol="o", symbolSize=3, symbolPen=None, symbolBrush=SNR_COLOR,
            name="per-frame SNR",
        )  # fmt: skip
        self.mean_curve = self.plot.plot(pen=pg.mkPen(MEAN_COLOR, width=2), name="100-frame mean")
        self._upper = pg.PlotDataItem(pen=pg.mkPen(MEAN_COLOR, width=0.5))
        self._lower = pg.PlotDataItem(pen=pg.mkPen(MEAN_COLOR, width=0.5))
        self.band = pg.FillBetweenItem(self._lower, self._upper, brush=pg.mkBrush(255, 211, 77, 50))
        for item in (self._upper, self._lower, self.band):
            self.plot.addItem(item)
        dash = pg.mkPen(MODEL_COLORS[0], width=2, style=Qt.PenStyle.DashLine)
        self.model_line = pg.InfiniteLine(
            angle=0, movable=False, pen=dash,
            label="model {value:.1f}", labelOpts={"position": 0.08, "color": MODEL_COLORS[0]},
        )  # fmt: skip
        self.model_line.setVisible(False)
        self.plot.addItem(self.model_line)
        self.setToolTip(
            f"{camera}: per-frame peak SNR (Eq. 4, dimensionless), the running mean of the last "
            "100 valid frames with a +/- 1 std band, and the model's SNR at the current range "
            "(dashed). Time axis in seconds before now."
        )
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(self.plot)

    def show_series(self, series: np.ndarray, now_ns: int) -> None:
        """Draw the rows of :meth:`CameraPipeline.series` within the last :data:`WINDOW_S`."""
        if series.size == 0:
            for c in (self.snr_curve, self.mean_curve, self._upper, self._lower):
                c.setData([], [])
            self.points_drawn = 0
            return
        t_s = (series[:, 0] - now_ns) / 1e9
        keep = t_s >= -WINDOW_S
        t_s, snr, mean, std = t_s[keep], series[keep, 1], series[keep, 2], series[keep, 3]
        ok = np.isfinite(snr)
        self.snr_curve.setData(t_s[ok], snr[ok])
        band_ok = np.isfinite(mean) & np.isfinite(std)
        self.mean_curve.setData(t_s[band_ok], mean[band_ok])
        self._upper.setData(t_s[band_ok], mean[band_ok] + std[band_ok])
        self._lower.setData(t_s[band_ok], mean[band_ok] - std[band_ok])
        self.points_drawn = int(ok.sum())

    def show_model(self, name: str, snr: float | None) -> None:
        """The model's SNR at the current range (None or NaN hides the line)."""
        visible = snr is not None and math.isfinite(snr)
        self.model_line.setVisible(visible)
        if visible:
            self.model_line.setValue(snr)
            self.model_line.label.setFormat(f"model ({name}) {{value:.1f}}")
