"""The console's stop table: its cells, one column per model value, sorting, and the CSV it
copies (the report's own, read back with the csv module)."""

from __future__ import annotations

import csv
import io

import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QApplication

from snrmon.acquisition.report.stop_csv import CSV_COLUMNS
from snrmon.acquisition.stops.table import ModelAtStop, StopPlace, StopReading, StopRow
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.gui.stop_table_view import StopTableView, columns, row_texts


def _cells(row: StopRow) -> dict[str, str]:
    return {c.key: t for c, t in zip(columns([row]), row_texts(row), strict=True)}


def _row(camera, stop, range_m, mean, sem, model, psf_source=None, **kw) -> StopRow:
    fields = {"camera": camera, "stop": stop, "manual": False, "t_start_ns": 0, "t_end_ns": 10}
    fields |= {"lrf_range_m": range_m, "gps_range_m": range_m, "n_frames": 100, "complete": True}
    fields |= {"snr_mean": mean, "snr_std": 3.0, "model_snr": model, "resolved": False}
    return StopRow.from_fields({**fields, "snr_sem": sem, **kw}, psf_source)


def test_console_stop_table_marks_a_resolved_short_stop():
    row = StopRow(
        "mwir",
        0,
        False,
        StopPlace(0, 10, 37.0, 37.0),
        StopReading(20, False, 2.47, 0.96, background="extent_rim+rim"),
        ModelAtStop({"small": 520.3}, resolved=True),
    )
    cells = _cells(row)
    assert cells["state"] == "ended short, resolved"
    assert cells["n_frames"] == "20" and cells["snr_mean"] == "2.47 ± --"  # no error of the mean
    assert cells["model_small"] == "520.3"  # the model's value in its own column
    assert cells["background"] == "extent_rim+rim"  # the background the stop was measured against
    assert "band" not in cells and "ratio" not in cells  # no expected reading: nothing to compare


def test_model_values_each_in_a_column_with_the_band_and_the_ratio_of_the_row_s_rule():
    model = {
        "small": 136.1,
        "large": 254.6,
        "small_corrected": 40.0,
        "large_corrected": 80.0,
        "expected_eq4_extent": 42.0,
        "expected_eq4_extent_lower": 38.0,
        "expected_eq4_extent_upper": 46.0,
        "expected_eq4_rim": 45.0,
    }
    row = _row("lwir", 3, 336.0, 47.5, 0.5, model, model_sky_temp_k=271.25, background="extent_rim")
    cells = _cells(row)
    assert [cells[f"model_{k}"] for k in ("small", "large", "small_corrected")] == [
        "136.1",
        "254.6",
        "40.0",
    ]
    assert cells["model_expected_eq4_extent"] == "42.0"
    assert cells["model_expected_eq4_rim"] == "45.0"
    assert not any(k.endswith(("_lower", "_upper")) for k in cells)  # the band is one column
    assert cells["band"] == "38.0–46.0"  # the extent rule's (the row's background)
    assert cells["ratio"] == f"{47.5 / 42.0:.2f} extent"
    assert cells["model_sky_temp_k"] == "271.2" or cells["model_sky_temp_k"] == "271.3"
    titles = {c.key: c.title for c in columns([row])}
    # units in the headers
    assert titles["lrf_range_m"] == "LRF\n(m)" and titles["model_sky_temp_k"] == "sky\n(K)"
    assert titles["model_expected_eq4_rim"] == "expected\n7x7 rim"


@pytest.fixture
def table(qtbot):
    view = StopTableView()
    qtbot.addWidget(view)
    view.resize(1600, 400)
    rim = {"background": "rim"}
    rows = [
        _row("mwir", 0, 126.0, 380.0, 4.0, {"small": 400.0, "expected_eq4_rim": 390.0}, **rim),
        _row("lwir", 0, 126.0, 150.0, 2.0, {"small": 160.0, "expected_eq4_rim": 140.0}, **rim),
        _row("mwir", 1, 508.0, 57.3, 1.0, {"small": 51.5, "expected_eq4_rim": 20.4}, **rim),
        _row("lwir", 1, 508.0, 21.5, 0.4, {"small": 17.6, "expected_eq4_rim": 23.3}, **rim),
    ]
    view.show_rows(rows)
    view.show()
    return view, rows


def test_the_table_sorts_by_a_column_s_number_not_its_text(table):
    view, rows = table
    keys = [c.key for c in view.table.cols]
    snr = keys.index("snr_mean")
    view.sortByColumn(snr, Qt.SortOrder.DescendingOrder)
    # by the number: 380 > 150 > 57.3 > 21.5 (as text "57.3" would sort above "380")
    assert [r.reading.snr_mean for r in view.shown_rows()] == [380.0, 150.0, 57.3, 21.5]
    view.sortByColumn(keys.index("ratio"), Qt.SortOrder.AscendingOrder)
    assert [
        r.reading.snr_mean / r.model.model_snr["expected_eq4_rim"] for r in view.shown_rows()
    ] == sorted(r.reading.snr_mean / r.model.model_snr["expected_eq4_rim"] for r in rows)


def test_copy_puts_the_report_csv_of_the_rows_shown_on_the_clipboard(table):
    view, rows = table
    keys = [c.key for c in view.table.cols]
    view.sortByColumn(keys.index("lrf_range_m"), Qt.SortOrder.DescendingOrder)
    assert view.copy_csv() == 4
    parsed = list(csv.DictReader(io.StringIO(QApplication.clipboard().text())))
    assert tuple(parsed[0]) == CSV_COLUMNS  # the report's columns
    assert [float(p["lrf_range_m"]) for p in parsed] == [508.0, 508.0, 126.0, 126.0]
    # full precision, read back to the same number
    want = {(r.camera, r.stop): r for r in rows}
    for p in parsed:
        r = want[(p["camera"], int(p["stop"]))]
        assert float(p["snr_mean"]) == r.reading.snr_mean
        assert float(p["model_small"]) == r.model.model_snr["small"]
        assert float(p["ratio_small"]) == pytest.approx(
            r.reading.snr_mean / r.model.model_snr["small"]
        )
    view.selectRow(0)  # a selection copies only what is selected
    assert view.copy_csv() == 1
    one = list(csv.DictReader(io.StringIO(QApplication.clipboard().text())))
    assert [(p["camera"], p["stop"]) for p in one] == [(parsed[0]["camera"], parsed[0]["stop"])]


def _verdict(mean: float, sem: float, lower: float, upper: float) -> str:
    """The band's verdict written out here (inside; near: within 2 errors of the mean of the
    nearer edge; outside), independent of the console's."""
    if lower <= mean <= upper:
        return "inside"
    return "near" if min(abs(mean - lower), abs(mean - upper)) <= 2 * sem else "outside"


def test_each_row_s_ratio_is_against_the_expected_reading_of_its_own_rule(qtbot):
    """Rows measured against the 7x7 rim and against the extent rim side by side (the two
    cameras, both rules at one range): each ratio cell is the row's mean over the expected
    reading of the row's own background's rule, named in the cell, coloured by its own band."""
    from snrmon.gui import theme as th

    def model(rim: float, extent: float) -> dict[str, float]:
        out = {"small": 2 * rim}
        for key, v in (("expected_eq4_rim", rim), ("expected_eq4_extent", extent)):
            out |= {key: v, f"{key}_lower": 0.9 * v, f"{key}_upper": 1.1 * v}
        return out

    rows = [  # (the paper's ranges; the extent rim's reading far below the rim's at 37 m)
        _row("mwir", 0, 37.0, 245.0, 3.0, model(16.0, 245.0), background="extent_rim+rim"),
        _row("lwir", 0, 37.0, 15.3, 0.5, model(15.5, 3.0), background="rim"),
        _row("mwir", 1, 126.0, 56.0, 1.0, model(3.6, 48.3), background="extent_rim"),
        _row("lwir", 1, 126.0, 9.0, 0.2, model(10.4, 9.9), background="rim"),
        _row("mwir", 2, 199.0, 8.0, 0.4, model(5.9, 5.9), background="rect"),  # no model of it
    ]
    view = StopTableView()
    qtbot.addWidget(view)
    view.resize(1600, 400)
    view.show_rows(rows)
    view.show()
    keys = [c.key for c in view.table.cols]
    ratio = keys.index("ratio")
    verdicts = th.current().verdicts
    seen = set()
    for i, row in enumerate(view.shown_rows()):
        index = view.proxy.index(i, ratio)
        if row.reading.background == "rect":
            assert index.data() == "--" and index.data(Qt.ItemDataRole.BackgroundRole) is None
            continue
        rule = "extent" if "extent_rim" in row.reading.background.split("+") else "rim"
        expected = row.model.model_snr[f"expected_eq4_{rule}"]
        assert index.data() == f"{row.reading.snr_mean / expected:.2f} {rule}", row
        verdict = _verdict(
            row.reading.snr_mean, row.reading.snr_sem, 0.9 * expected, 1.1 * expected
        )
        fill, ink = verdicts[verdict]
        assert index.data(Qt.ItemDataRole.BackgroundRole).color().name() == fill, row
        assert index.data(Qt.ItemDataRole.ForegroundRole).color().name() == ink, row
        assert "expected Eq. (4)" in index.data(Qt.ItemDataRole.ToolTipRole)
        seen.add((rule, verdict))
    # both rules, and verdicts that the other rule would have turned around
    assert {r for r, _ in seen} == {"rim", "extent"}
    assert ("inside", "extent") in {(v, r) for r, v in seen}


def test_rows_and_the_header_say_which_psf_the_model_used(qtbot):
    """The MWIR's first prediction uses the preset's PSF (solved for the paper's average PVF
    0.082); once a PSF is fitted from the flight's stops the model uses that. A stop row keeps
    the PSF its model values were computed with ("preset PSF" on the stop that ended before
    the fit, "fitted PSF" after it, in its own column and in full in the ratio's tooltip), and
    the camera header
    names the PSF of the current prediction, from the session's status."""
    import numpy as np

    from snrmon.acquisition.config import session_config_from_dict
    from snrmon.acquisition.engine.inputs import SetRoi
    from snrmon.acquisition.engine.session_engine import SessionEngine
    from snrmon.acquisition.prediction import ModelPredictor
    from snrmon.drivers.rangefinder.reading import RangeReading
    from snrmon.gui.camera_header import CameraHeader
    from tests.acquisition.replay.test_replay_model_psf import ESTIMATE

    h, w, x, y, frame_ns = 48, 64, 30, 20, 16_666_667

    def frame(i: int) -> np.ndarray:
        rng = np.random.default_rng([5, i])
        yy, xx = np.mgrid[0:h, 0:w]
        spot = 60.0 * np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * 0.8**2))
        return np.rint(1000.0 + spot + rng.normal(0.0, 5.0, (h, w))).astype(np.uint16)

    config = session_config_from_dict({"cameras": {"mwir": {"source": "shm", "address": "x"}}})
    predictor = ModelPredictor({"mwir": "mwir"}, "uav1")
    engine = SessionEngine(config, {"mwir": (h, w)}, predictor=predictor)
    engine.camera("mwir").post(SetRoi(x, y))

    def hover(first: int, range_m: float) -> int:
        t0 = 10**12 + first * frame_ns
        engine.mark_stop(t0)  # ends the stop before, if any
        for i in range(first, first + 130):
            t = 10**12 + i * frame_ns
            if i % 6 == 0:  # the rangefinder at 10 Hz
                engine.on_range(RangeReading(t, range_m, raw=f"{range_m:.1f}"))
            engine.on_frame(RingFrame(frame(i), i, i, t, None, "mwir"))
        return first + 130

    header = CameraHeader("mwir")
    qtbot.addWidget(header)
    view = StopTableView()
    qtbot.addWidget(view)
    view.resize(1600, 400)

    def psf_cells() -> list[tuple[str, str]]:
        """Each row's PSF cell and its ratio's tooltip, as shown."""
        view.show_rows(engine.stops())
        keys = [c.key for c in view.table.cols]
        psf, ratio = keys.index("psf"), keys.index("ratio")
        assert "psf" not in view.hidden_columns  # 1600 px: room for it
        return [
            (
                view.proxy.index(i, psf).data(),
                view.proxy.index(i, ratio).data(Qt.ItemDataRole.ToolTipRole),
            )
            for i in range(view.proxy.rowCount())
        ]

    n = hover(0, 336.0)
    header.show_status(engine.cameras["mwir"].status(), None)
    before = header.text()
    (cell,) = psf_cells()
    assert cell[0] == "preset PSF"
    assert cell[1].endswith("the model's PSF: preset: PVF 0.082 (sensor mwir)")
    assert "expected Eq. (4)" in before and "7x7 rim, preset PSF" in before
    assert header.tiles["expected"].toolTip().endswith("preset: PVF 0.082 (sensor mwir)")

    n = hover(n, 393.0)  # the first frame of this stop passes the first's end: final, preset
    engine.adopt_psf("mwir", ESTIMATE, 10**12 + n * frame_ns)
    # a third stop: the second ends now, after the fit, so its row freezes with the model in
    # force at its end (the fitted PSF), as the third's does
    hover(n, 393.0)
    header.show_status(engine.cameras["mwir"].status(), None)
    after = header.text()
    cells = psf_cells()
    rows = view.shown_rows()
    assert [r.final for r in rows] == [True, True, False]
    assert [c for c, _ in cells] == ["preset PSF", "fitted PSF", "fitted PSF"]
    assert cells[2][1].endswith("the model's PSF: fitted: sigma 0.57 px from this flight's stops")
    assert "7x7 rim, fitted PSF" in after and "preset PSF" not in after
    tip = header.tiles["expected"].toolTip()
    assert tip.endswith("fitted: sigma 0.57 px from this flight's stops")


def test_a_narrow_table_hides_the_curves_before_the_measured_over_expected(qtbot):
    """At the stop table's width on a 1366 x 768 first start (816 px) the paper's curves give
    way, the uncorrected first, so each row's measured / expected is in view without scrolling
    sideways; at 1600 px they are back."""
    model = {
        "small": 506.4,
        "large": 575.9,
        "small_corrected": 299.6,
        "large_corrected": 473.3,
        "expected_eq4_extent": 300.5,
        "expected_eq4_extent_lower": 282.5,
        "expected_eq4_extent_upper": 322.8,
        "expected_eq4_rim": 22.4,
    }
    rows = [
        _row(cam, stop, r, snr, 3.3, model, model_sky_temp_k=280.0, background="extent_rim")
        for stop, (r, snr) in enumerate(((37.0, 655.78), (126.0, 349.74)))
        for cam in ("mwir", "lwir")
    ]
    view = StopTableView()
    qtbot.addWidget(view)
    view.resize(816, 160)
    view.show()
    view.show_rows(rows)
    curves = ["model_small", "model_large", "model_small_corrected", "model_large_corrected"]
    gone = [c for c in curves if c in view.hidden_columns]
    assert gone and gone == curves[: len(gone)]  # in their order, the uncorrected first
    ratio = [c.key for c in view.table.cols].index("ratio")
    assert not view.isColumnHidden(ratio)
    right = view.columnViewportPosition(ratio) + view.columnWidth(ratio)
    assert 0 < right <= view.viewport().width()  # no scrolling to see it
    assert view.proxy.index(2, ratio).data() == "1.16 extent"
    view.resize(1600, 160)
    assert not set(curves) & set(view.hidden_columns)
