"""One camera's strip chart: per-frame peak SNR (Eq. 4), its 100-frame running mean with a
+/- one std band, and the model's prediction at the current range as a horizontal line.

Every number is the session's
(:meth:`snrmon.acquisition.runtime.camera_pipeline.CameraPipeline.series`, rows of
t_host_ns, snr, running mean, running std, range_m); the chart only converts times to seconds
before now and adds mean +/- std for the band's edges.

Drawing cost (the status timer redraws both charts every 400 ms while the cameras run): the
per-frame points are one :class:`DotsItem` (one ``drawPoints`` call; pyqtgraph's scatter item
spends ~5 ms of Python per 1800 points on per-point bookkeeping), square (a 3-px round dot is
stroked as a circle: 0.7 of a chart's 3.7 ms paint); the band is one closed polygon (pyqtgraph's
FillBetweenItem rebuilds two paths point by point, ~10 ms); the running mean and its band, smooth
from frame to frame, have at most a vertex per pixel column of the plot (the 2-px mean line of
1800 frames was 1.2 ms of the paint); and the axes, whose text and grid do not change when only
the points move, are cached as pixmaps. The y range is the chart's own (:func:`held_y_range`), not
pyqtgraph's auto-range: fitted afresh to every update, it moved at each one, and each move
redrew the left axis's text and grid and ran the auto-range over every item (the chart's paint
was up to 10 ms of the GUI thread's CPU at the 99th percentile, the console's longest but the
range plot's); held while the data stay well inside it, the axis stays a cached pixmap.
"""

from __future__ import annotations

import math

import numpy as np
import pyqtgraph as pg
from pyqtgraph import functions as fn
from PySide6.QtCore import QRectF, Qt
from PySide6.QtGui import QColor, QFont, QPainter, QPolygonF
from PySide6.QtWidgets import QGraphicsItem, QVBoxLayout, QWidget

from snrmon.gui import theme as th
from snrmon.gui.model_curves import curve_label
from snrmon.gui.plot_legend import PlotLegend, sample_icon

WINDOW_S = 30.0
Y_PAD = 0.1  # of the data's span, above and below, when the y range is fitted again
Y_FILL_MIN = 0.5  # the data's least share of the y range before it is fitted again


def held_y_range(
    shown: tuple[float, float] | None, lo: float, hi: float
) -> tuple[float, float] | None:
    """The y range to show data spanning ``lo`` to ``hi``: ``shown`` while it holds them with
    a margin and they fill at least :data:`Y_FILL_MIN` of it, else the data padded by
    :data:`Y_PAD` of their span each side, its ends rounded outwards to a tenth of the
    span's decade (so that it changes seldom, and to round numbers); None to keep ``shown``."""
    span = max(hi - lo, 1e-6 * max(abs(lo), abs(hi)), 1e-9)
    if shown is not None:
        r0, r1 = shown
        margin = 0.5 * Y_PAD * span
        if r0 <= lo - margin and hi + margin <= r1 and span >= Y_FILL_MIN * (r1 - r0):
            return None
    step = 10.0 ** math.floor(math.log10(span)) / 10.0
    return (
        math.floor((lo - Y_PAD * span) / step) * step,
        math.ceil((hi + Y_PAD * span) / step) * step,
    )


def cache_axes(plot: pg.PlotWidget) -> None:
    """Cache each axis (ticks, labels and its grid lines) as a pixmap: repainting points under
    the grid then blits it instead of replaying the text; an axis whose range changes still
    redraws (it calls ``update()``, which invalidates the cache)."""
    for name in ("left", "bottom", "right", "top"):
        axis = plot.getPlotItem().getAxis(name)
        axis.setCacheMode(QGraphicsItem.CacheMode.DeviceCoordinateCache)


def vertex_stride(n: int, width_px: float) -> np.ndarray:
    """The indices of ``n`` points along a curve kept to draw it ``width_px`` pixels wide: every
    point while there are no more than the pixel columns, else evenly one a column, the first
    and the last always."""
    columns = max(int(width_px), 2)
    if n <= columns:
        return np.arange(n)
    return np.unique(np.linspace(0, n - 1, columns).round().astype(np.intp))


class DotsItem(pg.GraphicsObject):
    """Points of a fixed on-screen size drawn in one ``QPainter.drawPoints`` call; gives the
    view its data bounds (for auto-range) like a pyqtgraph data item."""

    def __init__(self, colour: str, size_px: float) -> None:
        super().__init__()
        self._pen = pg.mkPen(colour, width=size_px)
        self._pen.setCosmetic(True)
        self._pen.setCapStyle(Qt.PenCapStyle.SquareCap)
        self._size_px = size_px
        self._xy = np.empty((0, 2))
        self._poly = QPolygonF()
        self._bounds: tuple[np.ndarray, np.ndarray] | None = None

    def set_points(self, x: np.ndarray, y: np.ndarray) -> None:
        """Replace the points (finite values only; the caller filters)."""
        self.prepareGeometryChange()
        self._xy = np.column_stack([x, y]).astype(float)
        self._poly = fn.create_qpolygonf(len(self._xy))
        self._bounds = None
        if len(self._xy):
            fn.ndarray_from_qpolygonf(self._poly)[:] = self._xy
            # min/max once here: Qt asks for the bounding rect several times a repaint
            self._bounds = (self._xy.min(axis=0), self._xy.max(axis=0))
        self.update()

    def set_colour(self, colour: str) -> None:
        self._pen.setColor(QColor(colour))
        self.update()

    def points(self) -> tuple[np.ndarray, np.ndarray]:
        return self._xy[:, 0].copy(), self._xy[:, 1].copy()

    def dataBounds(self, ax: int, frac: float = 1.0, orthoRange=None):  # noqa: N802 (pyqtgraph)
        if self._bounds is None:
            return None, None
        return float(self._bounds[0][ax]), float(self._bounds[1][ax])

    def pixelPadding(self) -> float:  # noqa: N802 (pyqtgraph's name)
        return self._size_px / 2

    def boundingRect(self) -> QRectF:  # noqa: N802 (Qt's name)
        if self._bounds is None:
            return QRectF()
        (x0, y0), (x1, y1) = self._bounds
        px, py = self.pixelVectors()
        pad_x = 0.0 if px is None else px.length() * self._size_px
        pad_y = 0.0 if py is None else py.length() * self._size_px
        return QRectF(x0 - pad_x, y0 - pad_y, x1 - x0 + 2 * pad_x, y1 - y0 + 2 * pad_y)

    def paint(self, painter: QPainter, *_args) -> None:
        if len(self._xy):
            painter.setPen(self._pen)
            painter.drawPoints(self._poly)


class StripChart(QWidget):
    """Peak SNR versus time (seconds before now) for one camera; its legend is a row of Qt
    widgets above the plot (never over the points), the model's reading at the current range
    is a dashed line across the window whose value is in its legend entry."""

    def __init__(self, camera: str, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.camera = camera
        self.points_drawn = 0
        self.plot = pg.PlotWidget()
        self.plot.setLabel("left", "peak SNR")
        self.plot.setLabel("bottom", "time before now (s)")
        self.plot.showGrid(x=True, y=True, alpha=0.25)
        self.plot.setXRange(-WINDOW_S, 0.0, padding=0.0)
        self.plot.getPlotItem().setMenuEnabled(False)
        # mean - std along the times, then mean + std back: one closed polygon, outlined
        self.band = pg.PlotCurveItem(fillLevel="enclosed")
        self.plot.addItem(self.band)
        self.snr_curve = DotsItem(th.current().snr, 3.0)
        self.plot.addItem(self.snr_curve)
        self.mean_curve = self.plot.plot()
        cache_axes(self.plot)
        self._model_shown: tuple[str, float] | None = None
        self._data_y: tuple[float, float] | None = None  # the points' and the band's extent
        self._y_shown: tuple[float, float] | None = None
        # The model's reading as data across the window (not an InfiniteLine): the y range
        # always takes it in, so the line is never off the plot, and it needs no label on it.
        self.model_line = self.plot.plot([], [])
        self.legend = PlotLegend(spacing=6)
        self.setToolTip(
            f"{camera}: per-frame peak SNR (Eq. 4, dimensionless), the running mean of the last "
            "100 valid frames with a +/- 1 std band, and the model's SNR at the current range "
            "(dashed). Time axis in seconds before now."
        )
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.setSpacing(2)
        lay.addWidget(self.legend)
        lay.addWidget(self.plot, 1)
        self.apply_theme(th.scaled_font(1.0))

    def apply_theme(self, font: QFont) -> None:
        """The current theme's colours and ``font`` on the plot and its legend."""
        t = th.current()
        th.style_plot(self.plot, font)
        mean = QColor(t.mean)
        fill = QColor(t.mean)
        fill.setAlpha(50)
        self.band.setPen(pg.mkPen(mean, width=0.5))
        self.band.setBrush(pg.mkBrush(fill))
        self.snr_curve.set_colour(t.snr)
        self.mean_curve.setPen(pg.mkPen(mean, width=2))
        self.model_line.setPen(pg.mkPen(t.model_line, width=2, style=Qt.PenStyle.DashLine))
        self.legend.clear()
        self.legend.add(
            "snr", "per frame", sample_icon(t.snr, kind="dot"), tip="Per-frame peak SNR (Eq. 4)"
        )
        self.legend.add(
            "mean",
            "mean ± std",
            sample_icon(t.mean, width=2),
            tip="Running mean of the last 100 valid frames, +/- their std (shaded)",
        )
        self.legend.add("model", self._model_text(), sample_icon(t.model_line, dashed=True))
        self._model_tip()

    def _model_text(self) -> str:
        if self._model_shown is None:
            return "model"
        return f"model {self._model_shown[1]:.1f}"

    def _model_tip(self) -> None:
        entry = self.legend.entries["model"]
        entry.setVisible(self._model_shown is not None)
        if self._model_shown is not None:
            entry.setToolTip(
                f"The model's {curve_label(self._model_shown[0])} at the current range (SNR)"
            )

    def show_series(self, series: np.ndarray, now_ns: int) -> None:
        """Draw the rows of :meth:`CameraPipeline.series` within the last :data:`WINDOW_S`."""
        if series.size == 0:
            self.snr_curve.set_points(np.empty(0), np.empty(0))
            self.mean_curve.setData([], [])
            self.band.setData([], [])
            self.points_drawn = 0
            self._data_y = None
            self._fit_y()
            return
        t_s = (series[:, 0] - now_ns) / 1e9
        keep = t_s >= -WINDOW_S
        t_s, snr, mean, std = t_s[keep], series[keep, 1], series[keep, 2], series[keep, 3]
        ok = np.isfinite(snr)
        self.snr_curve.set_points(t_s[ok], snr[ok])
        band_ok = np.flatnonzero(np.isfinite(mean) & np.isfinite(std))
        band_ok = band_ok[vertex_stride(len(band_ok), self.plot.getPlotItem().vb.width())]
        t_b, m_b, s_b = t_s[band_ok], mean[band_ok], std[band_ok]
        self.mean_curve.setData(t_b, m_b)
        self.band.setData(
            np.concatenate([t_b, t_b[::-1]]), np.concatenate([m_b - s_b, (m_b + s_b)[::-1]])
        )
        self.points_drawn = int(ok.sum())
        ys = [snr[ok], m_b - s_b, m_b + s_b]
        ys = [y for y in ys if len(y)]
        self._data_y = (
            (float(min(y.min() for y in ys)), float(max(y.max() for y in ys))) if ys else None
        )
        self._fit_y()

    def _fit_y(self) -> None:
        """Show the points, the band and the model's line (:func:`held_y_range`)."""
        lo_hi = [v for v in (self._data_y,) if v is not None]
        if self._model_shown is not None:
            lo_hi.append((self._model_shown[1], self._model_shown[1]))
        if not lo_hi:
            return
        lo, hi = min(v[0] for v in lo_hi), max(v[1] for v in lo_hi)
        fitted = held_y_range(self._y_shown, lo, hi)
        if fitted is not None:
            self._y_shown = fitted
            self.plot.setYRange(*fitted, padding=0.0)

    def show_model(self, name: str, snr: float | None) -> None:
        """The model's SNR at the current range (None or NaN hides the line)."""
        visible = snr is not None and math.isfinite(snr)
        shown = (name, float(snr)) if visible else None
        if shown == self._model_shown:
            return  # unchanged: no relayout of the legend, no repaint
        self._model_shown = shown
        self._model_tip()
        if visible:
            self.model_line.setData([-WINDOW_S, 0.0], [snr, snr])
            self.legend.set_text("model", self._model_text())
        else:
            self.model_line.setData([], [])
        self._fit_y()
