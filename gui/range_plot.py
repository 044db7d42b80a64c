"""SNR versus range for one camera (paper Figs. 7-10): the model's curves, its uncertainty band,
the measured stops with +/- one std error bars, and the live 100-frame point at the current range.

The curves come from an injected callable (:data:`CurveSource`), never computed here:
``curves(camera) -> {name: (ranges_m, snr)}``; an entry ``(ranges_m, snr_low, snr_high)`` is drawn
as a shaded band (the model's uncertainty) instead of a line.

The status timer calls :meth:`RangePlot.show_live` 5 times a second; an unchanged live point or
stop list is not set again (each ``setData`` repaints the whole plot, ~7 ms with its axes), and
the axes are cached as pixmaps (:func:`snrmon.gui.strip_chart.cache_axes`).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pyqtgraph as pg
from PySide6.QtWidgets import QVBoxLayout, QWidget

from snrmon.acquisition.stops.table import StopRow
from snrmon.gui.strip_chart import cache_axes
from snrmon.gui.theme import CAMERA_COLORS, MODEL_COLORS

Curves = Mapping[str, Sequence[np.ndarray]]
CurveSource = Callable[[str], Curves | None]
"""``curves(camera) -> {name: (ranges_m, snr)} | {name: (ranges_m, low, high)} | None``."""


MIN_SPAN_M = 600.0


def x_span_m(ranges_m: Sequence[float]) -> float:
    """The range axis' extent: 1.25 x the farthest range, up to the next 100 m, >= 600 m."""
    far = max((r for r in ranges_m if math.isfinite(r)), default=0.0)
    return max(MIN_SPAN_M, 100.0 * math.ceil(1.25 * far / 100.0))


def fit_title(rows: list[StopRow], expected: tuple[np.ndarray, np.ndarray] | None) -> str:
    """chi^2/dof of the unresolved stops (the model's small dimension under a pixel) against
    the model's expected Eq. (4) reading as the plot has it now (``expected``: ranges, snr),
    with the error of each mean; "" without such a stop or curve."""
    if expected is None:
        return ""
    lr, snr = np.log(np.asarray(expected[0], float)), np.asarray(expected[1], float)
    terms = [
        (r.snr_mean - float(np.interp(math.log(r.range_m), lr, snr))) ** 2 / r.snr_sem**2
        for r in rows
        if r.resolved is False and r.range_m and r.snr_sem > 0
    ]
    if not terms:
        return ""
    chi2 = sum(terms) / len(terms)
    return f"chi2/dof against the expected Eq. (4): {chi2:.2f} ({len(terms)} stops)"


class RangePlot(QWidget):
    """The SNR-versus-range plot of one camera."""

    def __init__(self, camera: str, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.camera = camera
        self.plot = pg.PlotWidget()
        self.plot.setLabel("left", "peak SNR")
        self.plot.setLabel("bottom", "range", units="m")
        self.plot.showGrid(x=True, y=True, alpha=0.25)
        self.plot.addLegend(offset=(-5, 5), labelTextSize="8pt")
        self.curve_items: dict[str, pg.GraphicsObject] = {}
        colour = CAMERA_COLORS.get(camera, "#ffffff")
        self.errors = pg.ErrorBarItem(x=np.array([]), y=np.array([]), pen=pg.mkPen(colour))
        self.plot.addItem(self.errors)
        self.stops = self.plot.plot(
            pen=None,
            symbol="s",
            symbolSize=8,
            symbolBrush=colour,
            symbolPen="k",
            name="stops (mean +/- error of the mean)",
        )
        self.live_errors = pg.ErrorBarItem(x=np.array([]), y=np.array([]), pen=pg.mkPen("#ffffff"))
        self.plot.addItem(self.live_errors)
        self.live = self.plot.plot(
            pen=None, symbol="star", symbolSize=14, symbolBrush="#ffffff", name="live (100 frames)"
        )
        # The model's curves run to several km; the stops of a day sit within the first few
        # hundred metres. Show 0 to 1.25 x the farthest measured range (at least 600 m, the
        # paper's 508 m stop with room), y fitted to what is in view, until the operator zooms.
        self._x_span_m = MIN_SPAN_M
        self._operator_zoomed = False
        view = self.plot.getViewBox()
        view.setXRange(0.0, self._x_span_m, padding=0.0)
        view.setAutoVisible(y=True)
        view.enableAutoRange(axis="y")
        view.sigRangeChangedManually.connect(self._zoomed)
        cache_axes(self.plot)
        self._stops_shown: list[tuple[float, float, float]] = []
        self._rows: list[StopRow] = []
        self._expected = None
        self._live_shown: tuple[float, float, float] | None = None
        self.setToolTip(
            f"{camera}: peak SNR (dimensionless) versus range (m). Lines: the model's curves; "
            "shaded: the model's uncertainty; squares: measured stops, mean +/- the error of the "
            "mean of their 100 frames; star: the live 100-frame mean +/- std at the current range."
        )
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.addWidget(self.plot)

    def _zoomed(self, *_args) -> None:
        self._operator_zoomed = True

    def _follow(self, ranges_m: Sequence[float]) -> None:
        span = x_span_m(ranges_m)
        if span > self._x_span_m and not self._operator_zoomed:
            self._x_span_m = span
            self.plot.getViewBox().setXRange(0.0, span, padding=0.0)

    def set_curves(self, curves: Curves | None) -> None:
        """Replace the model curves (None or empty draws none); the fit statistic follows the
        expected Eq. (4) curve of the console's rule (the sky-following one where there is
        one)."""
        names = [n for n in (curves or {}) if n.startswith("expected_eq4") and "band" not in n]
        names.sort(key=lambda n: ("@ sky" not in n, "extent" not in n))
        self._expected = tuple((curves or {})[names[0]]) if names else None
        self.plot.setTitle(fit_title(self._rows, self._expected), size="8pt")
        for item in self.curve_items.values():
            self.plot.removeItem(item)
        self.curve_items = {}
        for i, (name, data) in enumerate((curves or {}).items()):
            colour = MODEL_COLORS[i % len(MODEL_COLORS)]
            arrays = [np.asarray(a, dtype=float) for a in data]
            if len(arrays) == 2:
                pen = pg.mkPen(colour, width=2)
                item = self.plot.plot(arrays[0], arrays[1], pen=pen, name=name)
            elif len(arrays) == 3:
                lo = pg.PlotDataItem(arrays[0], arrays[1], pen=pg.mkPen(colour, width=0.5))
                hi = pg.PlotDataItem(arrays[0], arrays[2], pen=pg.mkPen(colour, width=0.5))
                c = pg.mkColor(colour)
                c.setAlpha(45)
                item = pg.FillBetweenItem(lo, hi, brush=pg.mkBrush(c))
                self.plot.addItem(item)
                self.plot.addItem(lo)
                self.plot.addItem(hi)
                self.curve_items[name + " low"] = lo
                self.curve_items[name + " high"] = hi
            else:
                raise ValueError(
                    f"model curve {name!r} of {self.camera}: expected (ranges_m, snr) or "
                    f"(ranges_m, low, high), got {len(arrays)} arrays"
                )
            self.curve_items[name] = item

    def show_stops(self, rows: list[StopRow]) -> None:
        """The stops of this camera that have a range and at least one valid frame, with the
        error of their mean (the frames' autocorrelation counted; the per-frame std where it is
        not known), and the chi^2/dof of the unresolved ones against the expected Eq. (4)."""
        mine = [
            r
            for r in rows
            if r.camera == self.camera and r.range_m is not None and math.isfinite(r.snr_mean)
        ]
        pts = [
            (r.range_m, r.snr_mean, r.snr_sem if math.isfinite(r.snr_sem) else r.snr_std)
            for r in mine
        ]
        if pts == self._stops_shown:
            return
        self._stops_shown = pts
        self._rows = mine
        self.plot.setTitle(fit_title(mine, self._expected), size="8pt")
        if not pts:
            self.stops.setData([], [])
            self.errors.setData(x=np.array([]), y=np.array([]))
            return
        x, y, s = (np.array(v, dtype=float) for v in zip(*pts, strict=True))
        self._follow(x.tolist())
        s = np.nan_to_num(s)
        self.stops.setData(x, y)
        self.errors.setData(x=x, y=y, height=2 * s, beam=0.0)

    def show_live(self, range_m: float | None, snr_mean: float, snr_std: float) -> None:
        """The live running mean +/- std at the current range (hidden when either is unknown)."""
        if range_m is None or not math.isfinite(snr_mean) or not math.isfinite(range_m):
            live = None
        else:
            live = (range_m, snr_mean, snr_std if math.isfinite(snr_std) else 0.0)
        if live == self._live_shown:  # (None at first: nothing is drawn yet either)
            return
        self._live_shown = live
        if live is None:
            self.live.setData([], [])
            self.live_errors.setData(x=np.array([]), y=np.array([]))
            return
        std = live[2]
        self._follow([range_m])
        self.live.setData([range_m], [snr_mean])
        self.live_errors.setData(
            x=np.array([range_m]), y=np.array([snr_mean]), height=np.array([2 * std]), beam=0.0
        )
