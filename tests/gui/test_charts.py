"""The strip chart's and the range plot's cheap drawing items show the session's numbers."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.gui.range_plot import RangePlot
from snrmon.gui.strip_chart import WINDOW_S, StripChart


def _series(n: int, now_ns: int) -> np.ndarray:
    rng = np.random.default_rng(11)
    t = now_ns - (np.arange(n)[::-1] * 1e9 / 60.0)
    snr = 12.0 + rng.normal(0.0, 1.0, n)
    snr[5] = np.nan  # an invalid frame is not drawn
    mean = np.full(n, 12.0)
    mean[:100] = np.nan  # no running mean before 100 frames
    std = np.full(n, 0.5)
    return np.column_stack([t, snr, mean, std, np.full(n, np.nan)])


def test_strip_chart_draws_the_points_the_mean_and_its_band(qtbot):
    chart = StripChart("mwir")
    qtbot.addWidget(chart)
    now = 10**12
    series = _series(2400, now)  # 40 s at 60 fps: the first 10 s fall outside the window
    chart.show_series(series, now)
    t_s = (series[:, 0] - now) / 1e9
    keep = (t_s >= -WINDOW_S) & np.isfinite(series[:, 1])
    x, y = chart.snr_curve.points()
    np.testing.assert_allclose(x, t_s[keep])
    np.testing.assert_allclose(y, series[keep, 1])
    assert chart.points_drawn == keep.sum()
    bx, by = chart.band.getData()
    assert by.min() == pytest.approx(11.5) and by.max() == pytest.approx(12.5)
    assert bx.min() >= -WINDOW_S and len(bx) == 2 * len(chart.mean_curve.getData()[0])
    # the view's auto-range takes in every point
    (_, _), (y0, y1) = chart.plot.getPlotItem().getViewBox().childrenBounds()
    assert y0 <= y.min() and y1 >= y.max()
    chart.show_series(np.empty((0, 5)), now)
    assert chart.points_drawn == 0 and len(chart.snr_curve.points()[0]) == 0


def test_strip_chart_model_line_follows_and_hides(qtbot):
    chart = StripChart("lwir")
    qtbot.addWidget(chart)
    chart.show_model("small", 9.5)
    assert chart.model_line.isVisible() and chart.model_line.value() == pytest.approx(9.5)
    chart.show_model("small", 9.5)  # unchanged: still shown
    assert chart.model_line.isVisible()
    chart.show_model("small", float("nan"))
    assert not chart.model_line.isVisible()
    chart.show_model("small", 7.0)
    assert chart.model_line.isVisible() and chart.model_line.value() == pytest.approx(7.0)


def _n_live(plot: RangePlot) -> int:
    x, _ = plot.live.getData()
    return 0 if x is None else len(x)


def test_range_plot_live_point_follows_changes_and_hides(qtbot):
    plot = RangePlot("mwir")
    qtbot.addWidget(plot)
    plot.show_live(None, float("nan"), float("nan"))
    assert _n_live(plot) == 0
    plot.show_live(200.0, 12.0, 1.0)
    plot.show_live(200.0, 12.0, 1.0)  # the same again changes nothing
    x, y = plot.live.getData()
    assert list(x) == [200.0] and list(y) == [12.0]
    plot.show_live(250.0, 11.0, float("nan"))  # an unknown std draws no error bar
    x, y = plot.live.getData()
    assert list(x) == [250.0] and list(y) == [11.0]
    assert plot.live_errors.opts["height"][0] == 0.0
    plot.show_live(None, 11.0, 1.0)
    assert _n_live(plot) == 0


def _x_range(plot: RangePlot) -> list[float]:
    return plot.plot.getViewBox().viewRange()[0]


def _row(rng_m: float, snr: float):
    from snrmon.acquisition.stops.table import StopRow

    return StopRow("mwir", 0, False, 0, 1, rng_m, rng_m, 100, True, snr, 1.0)


def test_range_plot_shows_the_stops_not_the_model_s_kilometres(qtbot):
    plot = RangePlot("mwir")
    qtbot.addWidget(plot)
    km = np.linspace(37.0, 5000.0, 200)
    plot.set_curves({"small": (km, 5e4 / km)})
    assert _x_range(plot) == pytest.approx([0.0, 600.0])
    plot.show_stops([_row(199.0, 380.0), _row(508.0, 57.0)])
    assert _x_range(plot) == pytest.approx([0.0, 700.0])  # 1.25 x 508 -> 700
    plot.show_live(760.0, 9.0, 1.0)
    assert _x_range(plot) == pytest.approx([0.0, 1000.0])
    plot.plot.getViewBox().sigRangeChangedManually.emit([True, True])  # the operator zooms
    plot.show_live(1500.0, 3.0, 1.0)
    assert _x_range(plot) == pytest.approx([0.0, 1000.0])


def test_strip_chart_model_label_lies_inside_the_plot(qtbot):
    chart = StripChart("mwir")
    qtbot.addWidget(chart)
    chart.resize(500, 300)
    chart.show()
    qtbot.waitExposed(chart)
    chart.show_series(_series(600, 10**12), 10**12)
    chart.show_model("small", 12.0)
    view = chart.plot.getPlotItem().getViewBox()
    label = chart.model_line.label

    def inside() -> bool:  # the label is placed once the view has laid out its range
        rect = label.mapRectToScene(label.boundingRect())
        return view.mapRectToScene(view.boundingRect()).contains(rect)

    qtbot.waitUntil(inside, timeout=2000)
    assert label.toPlainText() == "model (small) 12.0"


def test_range_plot_error_bars_are_the_error_of_the_mean_and_the_title_the_fit(qtbot):
    """The stops' bars are the error of the mean, not the per-frame std, and the title states
    chi2/dof of the unresolved stops against the expected Eq. (4) curve shown."""
    import numpy as np

    from snrmon.acquisition.stops.table import StopRow
    from snrmon.gui.range_plot import RangePlot, fit_title

    def row(stop, r, mean, sem, resolved=False):
        return StopRow(
            "mwir",
            stop,
            False,
            0,
            1,
            r,
            r,
            100,
            True,
            mean,
            10.0,
            {"expected_eq4_extent": 0.0},
            resolved,
            snr_sem=sem,
        )

    rows = [row(0, 199.0, 90.0, 2.0, True), row(1, 393.0, 60.0, 2.0), row(2, 508.0, 33.0, 1.0)]
    expected = (np.array([100.0, 1000.0]), np.array([64.0, 64.0]))
    # (60-64)^2/4 = 4 and (33-64)^2/1 = 961: the resolved stop is left out
    assert fit_title(rows, expected) == "chi2/dof against the expected Eq. (4): 482.50 (2 stops)"
    assert fit_title(rows, None) == ""
    plot = RangePlot("mwir")
    qtbot.addWidget(plot)
    plot.set_curves({"expected_eq4_extent": expected})
    plot.show_stops(rows)
    assert [p[2] for p in plot._stops_shown] == [2.0, 2.0, 1.0]  # not the std of 10
