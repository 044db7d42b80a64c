"""SNR versus range for one camera, read like the paper's Figs. 7-10: the model's four curves
(small and large characteristic dimension, uncorrected and corrected) named in words, the
expected Eq. (4) reading with its uncertainty band, the measured stops with their error of the
mean, and the live 100-frame point at the current range.

The curves come from an injected callable (:data:`CurveSource`), never computed here:
``curves(camera) -> {name: (ranges_m, snr)}``; an entry ``(ranges_m, snr_low, snr_high)`` (named
``"<curve> band"``) is drawn as a shaded band. A curve computed at the measured sky is named
``"<curve> @ sky <T> K"`` (:mod:`snrmon.gui.model_curves`): the curves are drawn once, at the sky
the stop rows used (the measured one where there is one); the other background's curves are
behind the "other background" switch.

The legend is a row of Qt widgets under the plot (:class:`snrmon.gui.plot_legend.PlotLegend`),
never over the data; a band's entry switches it on or off, and the legend folds away. Range and
SNR axes are linear or logarithmic as the operator chooses. The title states chi^2/dof of the
unresolved stops against the expected Eq. (4) reading, as the stop rows carry it
(:func:`snrmon.acquisition.report.comparison.stop_rows_fit`).

The console calls :meth:`RangePlot.show_live` once a second, with the stop table; an unchanged
live point or stop list is not set again (each ``setData`` repaints the whole plot, ~7 ms with
its axes), and the axes are cached as pixmaps (:func:`snrmon.gui.strip_chart.cache_axes`), and
so are the model's curves and bands (:func:`cache_curve`): they change only with the model, and
replaying their paths (a few km of curve, the bands' fills) was most of the plot's repaint when a
stop or the live point moved.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence

import numpy as np
import pyqtgraph as pg
from PySide6.QtCore import Qt
from PySide6.QtGui import QColor, QFont
from PySide6.QtWidgets import QCheckBox, QGraphicsItem, QVBoxLayout, QWidget

from snrmon.acquisition.report.comparison import stop_rows_fit
from snrmon.acquisition.stops.table import StopRow
from snrmon.gui import theme as th
from snrmon.gui.flow_layout import FlowBox
from snrmon.gui.model_curves import curve_label, is_expected, split_sky
from snrmon.gui.plot_legend import PlotLegend, caption, sample_icon
from snrmon.gui.strip_chart import cache_axes

Curves = Mapping[str, Sequence[np.ndarray]]
CurveSource = Callable[[str], Curves | None]
"""``curves(camera) -> {name: (ranges_m, snr)} | {name: (ranges_m, low, high)} | None``."""


MIN_SPAN_M = 600.0
LOG_NEAR_M = 20.0  # the near end of a logarithmic range axis
STOPS = "stops"
LIVE = "live"
EXPECTED_BANDS = "expected band"
CURVE_BANDS = "curve bands"
BAND_WORDS = {
    EXPECTED_BANDS: "expected Eq. (4): model uncertainty",
    CURVE_BANDS: "corrected curves: model uncertainty",
}


def cache_curve(item: pg.GraphicsObject) -> None:
    """Keep ``item``'s drawing as a pixmap of the screen's pixels: a repaint of the plot for
    its stops or live point then blits it; a change of the view's range or of the item redraws
    it once. A data item paints nothing itself: its curve and symbols are its children, each
    cached (Qt caches an item's own drawing, not its children's)."""
    for part in (item, *item.childItems()):
        part.setCacheMode(QGraphicsItem.CacheMode.DeviceCoordinateCache)


def x_span_m(ranges_m: Sequence[float]) -> float:
    """The range axis' extent: 1.25 x the farthest range, up to the next 100 m, >= 600 m."""
    far = max((r for r in ranges_m if math.isfinite(r)), default=0.0)
    return max(MIN_SPAN_M, 100.0 * math.ceil(1.25 * far / 100.0))


def fit_title(rows: list[StopRow], camera: str, rule: str | None) -> str:
    """chi^2/dof of ``camera``'s unresolved stops against the expected reading ``rule`` as the
    rows carry it (the errors: each stop's error of the mean and the model's band); "" without
    such a stop."""
    if not rule:
        return ""
    fit = stop_rows_fit(rows, camera, rule)
    if fit is None:
        return ""
    n = fit.n_stops
    return f"chi2/dof vs {curve_label(rule)}: {fit.chi2_per_dof:.2f} ({n} stop{'s' * (n != 1)})"


def error_bars(
    x: np.ndarray, y: np.ndarray, err: np.ndarray, log_x: bool, log_y: bool
) -> dict[str, np.ndarray]:
    """``y +/- err`` at ``x`` as an ErrorBarItem's arguments on the plot's axes (pyqtgraph's
    error bars do not follow a log axis by themselves): in log10 units on a log axis, where a
    bar's lower end below zero SNR is cut at a thousandth of the point."""
    err = np.nan_to_num(np.asarray(err, float))
    if log_y:
        keep = y > 0
        x, y, err = x[keep], y[keep], err[keep]
        top = np.log10(y + err) - np.log10(y)
        bottom = np.log10(y) - np.log10(np.maximum(y - err, y * 1e-3))
        y = np.log10(y)
    else:
        top = bottom = err
    if log_x:
        keep = x > 0
        x, y, top, bottom = x[keep], y[keep], top[keep], bottom[keep]
        x = np.log10(x)
    return {"x": x, "y": y, "top": top, "bottom": bottom}


class RangePlot(QWidget):
    """The SNR-versus-range plot of one camera (module docstring)."""

    def __init__(self, camera: str, parent: QWidget | None = None) -> None:
        super().__init__(parent)
        self.camera = camera
        self.rule: str | None = None  # the expected reading the title's fit is against
        self._make_plot()
        self._make_switches()
        self.setToolTip(
            f"{camera}: peak SNR (dimensionless) versus range (m). Lines: the model's curves "
            "(dashed uncorrected: diffraction-limited PSF, point target; solid corrected: real "
            "PSF, finite target size); shaded: the model's uncertainty; squares: measured stops, "
            "mean +/- the error of the mean of their 100 frames; star: the live 100-frame mean "
            "+/- its error at the current range."
        )
        self._lay_out()
        self.apply_theme(th.scaled_font(1.0))

    def _make_plot(self) -> None:
        """The plot, its stops' and the live mean's markers and error bars, its range."""
        self.plot = pg.PlotWidget()
        self.plot.setLabel("left", "peak SNR (Eq. 4)")
        self.plot.setLabel("bottom", "range (m)")
        self.plot.showGrid(x=True, y=True, alpha=0.25)
        self.plot.getPlotItem().setMenuEnabled(False)  # its log/grid menu would bypass ours
        self.curve_items: dict[str, pg.GraphicsObject] = {}
        self._curves: dict[str, list[np.ndarray]] = {}
        self._shown: dict[str, bool] = {}  # operator's choice per legend key
        self.errors = pg.ErrorBarItem(x=np.array([]), y=np.array([]))
        self.plot.addItem(self.errors)
        self.stops = self.plot.plot(pen=None, symbol="s", symbolSize=9)
        self.live_errors = pg.ErrorBarItem(x=np.array([]), y=np.array([]))
        self.plot.addItem(self.live_errors)
        self.live = self.plot.plot(pen=None, symbol="star", symbolSize=16)
        for item in (self.errors, self.stops, self.live_errors, self.live):
            item.setZValue(10)  # the measurements over the model
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
        self._live_shown: tuple[float, float, float] | None = None

    def _make_switches(self) -> None:
        """The title, what the curves are computed at, the axis and legend switches."""
        self.title = caption("", "chi^2 per degree of freedom of the unresolved stops")
        self.basis = caption("", "The background the model's curves are computed at")
        self.log_x = QCheckBox("log range")
        self.log_y = QCheckBox("log SNR")
        self.other = QCheckBox("other background")
        self.other.setToolTip(
            "Also draw the curves at the model's own background (or, with the model's own in "
            "view, at the measured sky): thin dotted lines"
        )
        self.legend_switch = QCheckBox("legend")
        self.legend_switch.setChecked(True)
        for box in (self.log_x, self.log_y, self.other, self.legend_switch):
            box.setFocusPolicy(Qt.FocusPolicy.NoFocus)  # the keys belong to the shortcuts
        self.log_x.setToolTip("Logarithmic range axis")
        self.log_y.setToolTip("Logarithmic SNR axis")
        self.legend_switch.setToolTip("Show or fold the legend under the plot")
        self.log_x.toggled.connect(self._log_changed)
        self.log_y.toggled.connect(self._log_changed)
        self.other.toggled.connect(lambda _on: self._apply_visibility())
        self.legend = PlotLegend()
        self.legend.toggled.connect(self._legend_toggled)
        self.legend_switch.toggled.connect(self.legend.setVisible)

    def _lay_out(self) -> None:
        # The title, what the curves are computed at and the switches, wrapped by width.
        self.bar = FlowBox(spacing=12)
        bar = self.bar.flow
        bar.setContentsMargins(4, 2, 4, 0)
        for widget in (self.title, self.basis, self.log_x, self.log_y, self.other):
            bar.addWidget(widget)
        bar.addWidget(self.legend_switch)
        lay = QVBoxLayout(self)
        lay.setContentsMargins(0, 0, 0, 0)
        lay.setSpacing(2)
        lay.addWidget(self.bar)
        lay.addWidget(self.plot, 1)
        lay.addWidget(self.legend)

    # ------------------------------------------------------------------ theme
    def apply_theme(self, font: QFont) -> None:
        """The current theme's colours and ``font`` on the plot, its markers and curves."""
        t = th.current()
        th.style_plot(self.plot, font)
        colour = t.camera_colour(self.camera)
        self.errors.setData(pen=pg.mkPen(colour, width=1.5))
        self.stops.setSymbolBrush(colour)
        self.stops.setSymbolPen(pg.mkPen(t.text, width=1))
        self.live_errors.setData(pen=pg.mkPen(t.live, width=1.5))
        self.live.setSymbolBrush(t.live)
        self.live.setSymbolPen(pg.mkPen(colour, width=1))
        self._draw_curves()

    # ------------------------------------------------------------------ axes
    def _zoomed(self, *_args) -> None:
        self._operator_zoomed = True

    def _set_x_range(self) -> None:
        view = self.plot.getViewBox()
        if self.log_x.isChecked():
            view.setXRange(math.log10(LOG_NEAR_M), math.log10(self._x_span_m), padding=0.0)
        else:
            view.setXRange(0.0, self._x_span_m, padding=0.0)

    def _follow(self, ranges_m: Sequence[float]) -> None:
        span = x_span_m(ranges_m)
        if span > self._x_span_m and not self._operator_zoomed:
            self._x_span_m = span
            self._set_x_range()

    def _log_changed(self, *_args) -> None:
        self.plot.setLogMode(x=self.log_x.isChecked(), y=self.log_y.isChecked())
        self._operator_zoomed = False
        self._set_x_range()
        self.plot.getViewBox().enableAutoRange(axis="y")
        self._draw_stops()
        self._draw_live()

    # ------------------------------------------------------------------ the model's curves
    def set_curves(self, curves: Curves | None) -> None:
        """Replace the model curves (None or empty draws none)."""
        self._curves = {}
        for name, data in (curves or {}).items():
            arrays = [np.asarray(a, dtype=float) for a in data]
            if len(arrays) not in (2, 3):
                raise ValueError(
                    f"model curve {name!r} of {self.camera}: expected (ranges_m, snr) or "
                    f"(ranges_m, low, high), got {len(arrays)} arrays"
                )
            self._curves[name] = arrays
        self._draw_curves()

    def _primary_sky(self) -> str | None:
        """The sky label of the curves drawn as the model ("" for the model's own background):
        the measured sky's where there are such curves (the stop rows use them)."""
        skies = sorted({split_sky(n)[1] for n in self._curves} - {""})
        return skies[-1] if skies else ""

    def _draw_curves(self) -> None:
        for item in self.curve_items.values():
            self.plot.removeItem(item)
        self.curve_items = {}
        self.legend.clear()
        t = th.current()
        primary = self._primary_sky()
        if primary:
            self.basis.setText(f"model at the measured {primary}")
        elif self._curves:
            self.basis.setText("model at its own background (no sky measured)")
        else:
            self.basis.setText("no model curves")
        self.other.setEnabled(any(split_sky(n)[1] != primary for n in self._curves))
        self.legend.add(
            STOPS,
            "stops ± error of the mean",
            sample_icon(t.camera_colour(self.camera), kind="bar"),
        )
        self.legend.add(LIVE, "live (100 frames)", sample_icon(t.live, kind="star"))
        for i, (name, arrays) in enumerate(self._curves.items()):
            base, sky = split_sky(name)
            is_band = base.endswith(" band")
            curve = base[: -len(" band")] if is_band else base
            style = t.curve_style(curve, i)
            main = sky == primary
            if is_band:
                lo = pg.PlotDataItem(arrays[0], arrays[1], pen=th.pen(style, 90))
                hi = pg.PlotDataItem(arrays[0], arrays[2], pen=th.pen(style, 90))
                c = QColor(style.colour)
                c.setAlpha(50)
                fill = pg.FillBetweenItem(lo, hi, brush=pg.mkBrush(c))
                for part in (fill, lo, hi):
                    self.plot.addItem(part)
                    cache_curve(part)
                self.curve_items[name + " low"] = lo
                self.curve_items[name + " high"] = hi
                self.curve_items[name] = fill
                key = _band_key(curve)
                if main and key not in self.legend.entries:
                    self.legend.add(
                        key,
                        BAND_WORDS[key],
                        sample_icon(style.colour, kind="band"),
                        checkable=True,
                        shown=self._shown.get(key, key == EXPECTED_BANDS),
                        tip="The model's uncertainty band (paper section 9, Fig. 12); click "
                        "to show or hide",
                    )
            else:
                p = th.pen(style)
                if not main:
                    p = pg.mkPen(style.colour, width=1.0, style=Qt.PenStyle.DotLine)
                item = self.plot.plot(arrays[0], arrays[1], pen=p)
                cache_curve(item)
                self.curve_items[name] = item
                if main:
                    self.legend.add(
                        name,
                        curve_label(curve),
                        sample_icon(style.colour, dashed=style.dashed, width=style.width),
                    )
        self._apply_visibility()
        self.title.setText(fit_title(self._rows, self.camera, self._rule()))

    def _apply_visibility(self) -> None:
        primary = self._primary_sky()
        other = self.other.isChecked()
        for name in self._curves:
            base, sky = split_sky(name)
            main = sky == primary
            shown = main or other
            if base.endswith(" band"):
                key = _band_key(base[: -len(" band")])
                shown = shown and self._shown.get(key, key == EXPECTED_BANDS)
                for part in (name, name + " low", name + " high"):
                    self.curve_items[part].setVisible(shown)
            else:
                self.curve_items[name].setVisible(shown)

    def _legend_toggled(self, key: str, on: bool) -> None:
        self._shown[key] = on
        self._apply_visibility()

    def _rule(self) -> str | None:
        if self.rule:
            return self.rule
        names = [split_sky(n)[0] for n in self._curves]
        return next((n for n in names if is_expected(n) and not n.endswith(" band")), None)

    def set_rule(self, rule: str | None) -> None:
        """The expected reading the session compares against (the status names it)."""
        if rule != self.rule:
            self.rule = rule
            self.title.setText(fit_title(self._rows, self.camera, self._rule()))

    # ------------------------------------------------------------------ measurements
    def show_stops(self, rows: list[StopRow]) -> None:
        """The stops of this camera that have a range and at least one valid frame, with the
        error of their mean (the frames' autocorrelation counted; the per-frame std where it is
        not known), and the chi^2/dof of the unresolved ones against the expected Eq. (4)."""
        mine = [
            r
            for r in rows
            if r.camera == self.camera
            and r.range_m is not None
            and math.isfinite(r.reading.snr_mean)
        ]
        pts = [
            (
                r.range_m,
                r.reading.snr_mean,
                r.reading.snr_sem if math.isfinite(r.reading.snr_sem) else r.reading.snr_std,
            )
            for r in mine
        ]
        if pts == self._stops_shown:
            return
        self._stops_shown = pts
        self._rows = mine
        self.title.setText(fit_title(mine, self.camera, self._rule()))
        if pts:
            self._follow([p[0] for p in pts])
        self._draw_stops()

    def _draw_stops(self) -> None:
        self._draw_points(self.stops, self.errors, self._stops_shown)

    def _draw_points(
        self, marks: pg.PlotDataItem, bars: pg.ErrorBarItem, pts: Sequence[tuple]
    ) -> None:
        """``pts`` (range, SNR, error) as ``marks`` and their error ``bars``, every array of
        the bars given anew each time: pyqtgraph keeps any it is not given, so clearing x and y
        alone left the old top/bottom arrays beside empty ones (a shape mismatch it then paints
        with)."""
        x, y, s = np.array(pts, dtype=float).reshape(-1, 3).T
        marks.setData(x, y)
        bars.setData(
            **error_bars(x, y, s, self.log_x.isChecked(), self.log_y.isChecked()), beam=0.0
        )

    def show_live(self, range_m: float | None, snr_mean: float, snr_err: float) -> None:
        """The live running mean +/- ``snr_err`` (its error of the mean) at the current range
        (hidden when either is unknown)."""
        if range_m is None or not math.isfinite(snr_mean) or not math.isfinite(range_m):
            live = None
        else:
            live = (range_m, snr_mean, snr_err if math.isfinite(snr_err) else 0.0)
        if live == self._live_shown:  # (None at first: nothing is drawn yet either)
            return
        self._live_shown = live
        if live is not None:
            self._follow([live[0]])
        self._draw_live()

    def _draw_live(self) -> None:
        live = self._live_shown
        self._draw_points(self.live, self.live_errors, [] if live is None else [live])


def _band_key(curve: str) -> str:
    """The legend switch of a curve's band: one for the expected readings', one for the
    corrected curves'."""
    return EXPECTED_BANDS if is_expected(curve) else CURVE_BANDS
