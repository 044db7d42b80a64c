"""The strip chart's and the range plot's cheap drawing items show the session's numbers."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from snrmon.gui.legibility import data_rect, global_rect, text_cut
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


def test_vertex_stride_keeps_every_point_or_one_a_pixel_column():
    from snrmon.gui.strip_chart import vertex_stride

    assert vertex_stride(5, 700.0).tolist() == [0, 1, 2, 3, 4]
    kept = vertex_stride(1800, 700.0)
    assert len(kept) == 700 and kept[0] == 0 and kept[-1] == 1799
    assert np.all(np.diff(kept) >= 2) and np.all(np.diff(kept) <= 3)  # evenly spread
    assert vertex_stride(10, 0.0).tolist() == [0, 9]  # a chart not laid out yet: the ends


def test_strip_chart_draws_the_points_the_mean_and_its_band(qtbot):
    chart = StripChart("mwir")
    qtbot.addWidget(chart)
    chart.resize(700, 250)
    chart.show()
    qtbot.waitExposed(chart)
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
    # the smooth mean and band: a vertex a pixel column at most, from the first to the last
    mx, my = chart.mean_curve.getData()
    width = chart.plot.getPlotItem().vb.width()
    assert 300 < len(mx) <= width < keep.sum()
    assert mx[0] == t_s[keep][0] and mx[-1] == t_s[keep][-1]
    np.testing.assert_allclose(my, np.interp(mx, t_s, series[:, 2]))
    # the view's auto-range takes in every point
    (_, _), (y0, y1) = chart.plot.getPlotItem().getViewBox().childrenBounds()
    assert y0 <= y.min() and y1 >= y.max()
    chart.show_series(np.empty((0, 5)), now)
    assert chart.points_drawn == 0 and len(chart.snr_curve.points()[0]) == 0


def _model_y(chart: StripChart) -> list[float]:
    _, y = chart.model_line.getData()
    return [] if y is None else list(y)


def test_strip_chart_model_line_follows_and_hides(qtbot):
    chart = StripChart("lwir")
    qtbot.addWidget(chart)
    chart.show()
    chart.show_model("small", 9.5)
    entry = chart.legend.entries["model"]
    assert _model_y(chart) == [9.5, 9.5] and entry.isVisible() and entry.text() == "model 9.5"
    chart.show_model("small", 9.5)  # unchanged: still shown
    assert entry.isVisible()
    chart.show_model("small", float("nan"))
    assert _model_y(chart) == [] and not entry.isVisible()
    chart.show_model("expected_eq4_extent", 7.0)
    assert _model_y(chart) == [7.0, 7.0] and entry.text() == "model 7.0"
    assert "expected Eq. (4)" in entry.toolTip()  # which of the model's readings, in words


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
    plot.show_live(250.0, 11.0, float("nan"))  # an unknown error draws no error bar
    x, y = plot.live.getData()
    assert list(x) == [250.0] and list(y) == [11.0]
    assert plot.live_errors.opts["top"][0] == 0.0 and plot.live_errors.opts["bottom"][0] == 0.0
    plot.show_live(None, 11.0, 1.0)
    assert _n_live(plot) == 0


def _x_range(plot: RangePlot) -> list[float]:
    return plot.plot.getViewBox().viewRange()[0]


def _row(rng_m: float, snr: float):
    from snrmon.acquisition.stops.table import StopPlace, StopReading, StopRow

    return StopRow(
        "mwir", 0, False, StopPlace(0, 1, rng_m, rng_m), StopReading(100, True, snr, 1.0)
    )


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


def test_strip_chart_legend_and_model_line_lie_off_and_inside_the_data(qtbot):
    """The legend sits above the data area, never on it, and the model's line (whatever its
    value) lies inside the plotted range, so no part of it or its words is cut off."""
    chart = StripChart("mwir")
    qtbot.addWidget(chart)
    chart.resize(500, 300)
    chart.show()
    qtbot.waitExposed(chart)
    chart.show_series(_series(600, 10**12), 10**12)
    view = chart.plot.getPlotItem().getViewBox()
    for snr in (12.0, 40.0, 1.0):  # in the points, far above them, far below them
        chart.show_model("small", snr)
        assert view.viewRange()[1][0] < snr < view.viewRange()[1][1]  # set with the line
        # the legend's new words are laid out by the event loop's next pass
        qtbot.waitUntil(lambda: not text_cut(chart.legend.entries["model"]))
        assert not global_rect(chart.legend).intersects(data_rect(chart.plot))
        assert chart.legend.entries["model"].text() == f"model {snr:.1f}"


def test_range_plot_error_bars_are_the_error_of_the_mean_and_the_title_the_fit(qtbot):
    """The stops' bars are the error of the mean, not the per-frame std, and the title states
    chi2/dof of the unresolved stops against the expected Eq. (4) reading the rows carry."""
    from snrmon.acquisition.stops.table import ModelAtStop, StopPlace, StopReading, StopRow
    from snrmon.gui.range_plot import RangePlot, fit_title

    def row(stop, r, mean, sem, resolved=False):
        return StopRow(
            "mwir",
            stop,
            False,
            StopPlace(0, 1, r, r),
            StopReading(100, True, mean, 10.0, snr_sem=sem),
            ModelAtStop({"expected_eq4_extent": 64.0}, resolved),
        )

    rows = [row(0, 199.0, 90.0, 2.0, True), row(1, 393.0, 60.0, 2.0), row(2, 508.0, 33.0, 1.0)]
    # (60-64)^2/4 = 4 and (33-64)^2/1 = 961 (no band): the resolved stop is left out
    title = "chi2/dof vs expected Eq. (4), console's target-aware rim: 482.50 (2 stops)"
    assert fit_title(rows, "mwir", "expected_eq4_extent") == title
    assert (
        fit_title(rows, "mwir", None) == "" and fit_title(rows, "lwir", "expected_eq4_extent") == ""
    )
    plot = RangePlot("mwir")
    qtbot.addWidget(plot)
    r = np.array([100.0, 1000.0])
    plot.set_curves({"expected_eq4_extent": (r, np.array([64.0, 64.0]))})
    plot.show_stops(rows)
    assert [p[2] for p in plot._stops_shown] == [2.0, 2.0, 1.0]  # not the std of 10
    assert plot.title.text() == title
    # with a band of +/- 3 the misfit is weighed by sem^2 + 3^2: (16/13 + 961/10) / 2
    banded = [
        dataclasses.replace(
            x,
            model=dataclasses.replace(
                x.model,
                model_snr={
                    "expected_eq4_extent": 64.0,
                    "expected_eq4_extent_lower": 61.0,
                    "expected_eq4_extent_upper": 67.0,
                },
            ),
        )
        for x in rows
    ]
    assert fit_title(banded, "mwir", "expected_eq4_extent").endswith(
        f"{(16 / 13 + 961 / 10) / 2:.2f} (2 stops)"
    )


def _curves(sky: float | None = None) -> dict:
    r = np.geomspace(10.0, 5000.0, 50)
    own = {
        "small": (r, 9e4 / r),
        "large": (r, 2e5 / r),
        "small_corrected": (r, 3e4 / r),
        "large_corrected": (r, 6e4 / r),
        "expected_eq4_extent": (r, 3.1e4 / r),
        "small_corrected band": (r, 2.5e4 / r, 3.5e4 / r),
        "expected_eq4_extent band": (r, 2.6e4 / r, 3.6e4 / r),
    }
    if sky is None:
        return own
    out = dict(own)
    for name, data in own.items():
        out[f"{name} @ sky {sky:.1f} K"] = tuple(
            np.asarray(a) * (1.0 if i == 0 else 0.8) for i, a in enumerate(data)
        )
    return out


def test_range_plot_draws_the_curves_once_named_in_words_with_the_legend_off_the_data(qtbot):
    """Like the paper's Figs. 7-10: the four curves and the expected reading named in words,
    each once (at the measured sky when there is one; the model's own background behind the
    "other background" switch), the expected reading's band shown and the corrected curves'
    behind their legend switch; the legend under the data area, never on it."""
    plot = RangePlot("mwir")
    qtbot.addWidget(plot)
    plot.resize(700, 600)
    plot.show()
    qtbot.waitExposed(plot)
    plot.set_curves(_curves())
    words = plot.legend.texts()
    for label in (
        "small dimension, uncorrected",
        "large dimension, uncorrected",
        "small dimension, corrected",
        "large dimension, corrected",
        "expected Eq. (4), console's target-aware rim",
    ):
        assert words.count(label) == 1, words
    assert not any("@" in w for w in words)
    assert plot.curve_items["expected_eq4_extent band"].isVisible()
    assert not plot.curve_items["small_corrected band"].isVisible()
    plot.legend.entries["curve bands"].click()  # the operator switches the corrected bands on
    assert plot.curve_items["small_corrected band"].isVisible()

    plot.set_curves(_curves(sky=280.0))  # a measured sky: its curves are the ones drawn
    assert plot.basis.text() == "model at the measured sky 280.0 K"
    assert plot.curve_items["small @ sky 280.0 K"].isVisible()
    assert not plot.curve_items["small"].isVisible()
    assert plot.legend.texts().count("small dimension, uncorrected") == 1
    plot.other.click()  # the other background's curves too, on demand
    assert plot.curve_items["small"].isVisible()
    qtbot.waitUntil(lambda: data_rect(plot.plot).height() > 100)
    assert not global_rect(plot.legend).intersects(data_rect(plot.plot))


def test_range_plot_log_axes_keep_the_stops_and_their_error_bars(qtbot):
    """On log axes the stops' bars are drawn in decades (pyqtgraph's error bars do not follow a
    log axis by themselves): mean +/- error of the mean, back in linear units, is the stop's."""
    from snrmon.acquisition.stops.table import StopPlace, StopReading, StopRow

    plot = RangePlot("lwir")
    qtbot.addWidget(plot)
    plot.set_curves(_curves())
    row = StopRow(
        "lwir", 0, False, StopPlace(0, 1, 200.0, 200.0), StopReading(100, True, 50.0, 9.0, 4.0)
    )
    plot.show_stops([row])
    plot.log_x.click()
    plot.log_y.click()
    o = plot.errors.opts
    assert 10 ** o["x"][0] == pytest.approx(200.0)
    assert 10 ** (o["y"][0] + o["top"][0]) == pytest.approx(54.0)
    assert 10 ** (o["y"][0] - o["bottom"][0]) == pytest.approx(46.0)
    assert plot.plot.getPlotItem().getAxis("bottom").logMode
    plot.log_y.click()  # back to a linear SNR axis: plain +/- 4
    assert plot.errors.opts["top"][0] == pytest.approx(4.0)


def test_strip_chart_y_range_is_held_while_the_data_stay_well_inside_it():
    """The y range moves only when the data leave it or shrink to under half of it (each move
    redraws the axis), and then takes them in with round ends."""
    from snrmon.gui.strip_chart import held_y_range

    first = held_y_range(None, 412.3, 687.9)
    assert first == pytest.approx((380.0, 720.0))  # 10 % of the 275.6 span, to tens
    assert held_y_range(first, 420.0, 690.0) is None  # inside, most of it: held
    assert held_y_range(first, 420.0, 760.0) == pytest.approx((380.0, 800.0))  # above it
    assert held_y_range(first, 500.0, 560.0) == pytest.approx((494.0, 566.0))  # a fifth of it
