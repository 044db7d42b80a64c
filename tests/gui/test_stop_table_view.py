"""The console's stop table: its cells, one column per model value, sorting, and the CSV it
copies (the report's own, read back with the csv module)."""

from __future__ import annotations

import csv
import io

import pytest
from PySide6.QtCore import Qt
from PySide6.QtWidgets import QApplication

from snrmon.acquisition.report.stop_csv import CSV_COLUMNS
from snrmon.acquisition.stops.table import StopRow
from snrmon.gui.stop_table_view import StopTableView, columns, row_texts


def _cells(row: StopRow, rule: str | None = None) -> dict[str, str]:
    return {c.key: t for c, t in zip(columns([row], rule), row_texts(row, rule), strict=True)}


def _row(camera, stop, range_m, mean, sem, model, **kw) -> StopRow:
    return StopRow(
        camera,
        stop,
        False,
        0,
        10,
        range_m,
        range_m,
        100,
        True,
        mean,
        3.0,
        model,
        False,
        snr_sem=sem,
        **kw,
    )


def test_console_stop_table_marks_a_resolved_short_stop():
    row = StopRow(
        "mwir",
        0,
        False,
        0,
        10,
        37.0,
        37.0,
        20,
        False,
        2.47,
        0.96,
        {"small": 520.3},
        resolved=True,
        background="extent_rim+rim",
    )
    cells = _cells(row)
    assert cells["state"] == "ended short, resolved"
    assert cells["frames"] == "20" and cells["snr_mean"] == "2.47 ± --"  # no error of the mean
    assert cells["model:small"] == "520.3"  # the model's value in its own column
    assert cells["background"] == "extent_rim+rim"  # the background the stop was measured against
    assert "band" not in cells and "ratio" not in cells  # no expected reading: nothing to compare


def test_model_values_each_in_a_column_with_the_band_and_the_ratio_of_the_session_rule():
    model = {
        "small": 136.1,
        "large": 254.6,
        "small_corrected": 40.0,
        "large_corrected": 80.0,
        "expected_eq4": 42.0,
        "expected_eq4_lower": 38.0,
        "expected_eq4_upper": 46.0,
        "expected_eq4_rim": 45.0,  # a rule the console does not know yet gets its own column
    }
    row = _row("lwir", 3, 336.0, 47.5, 0.5, model, model_sky_temp_k=271.25)
    cells = _cells(row, "expected_eq4")
    assert [cells[f"model:{k}"] for k in ("small", "large", "small_corrected")] == [
        "136.1",
        "254.6",
        "40.0",
    ]
    assert cells["model:expected_eq4"] == "42.0" and cells["model:expected_eq4_rim"] == "45.0"
    assert not any(k.endswith(("_lower", "_upper")) for k in cells)  # the band is one column
    assert cells["band"] == "38.0–46.0"
    assert cells["ratio"] == f"{47.5 / 42.0:.2f}"
    assert cells["sky"] == "271.2" or cells["sky"] == "271.3"
    titles = {c.key: c.title for c in columns([row], "expected_eq4")}
    assert titles["lrf"] == "LRF\n(m)" and titles["sky"] == "sky\n(K)"  # units in the headers
    assert titles["model:expected_eq4_rim"] == "expected\n7x7 rim"


@pytest.fixture
def table(qtbot):
    view = StopTableView()
    qtbot.addWidget(view)
    view.resize(1600, 400)
    rows = [
        _row("mwir", 0, 126.0, 380.0, 4.0, {"small": 400.0, "expected_eq4": 390.0}),
        _row("lwir", 0, 126.0, 150.0, 2.0, {"small": 160.0, "expected_eq4": 140.0}),
        _row("mwir", 1, 508.0, 57.3, 1.0, {"small": 51.5, "expected_eq4": 20.4}),
        _row("lwir", 1, 508.0, 21.5, 0.4, {"small": 17.6, "expected_eq4": 23.3}),
    ]
    view.show_rows(rows, "expected_eq4")
    view.show()
    return view, rows


def test_the_table_sorts_by_a_column_s_number_not_its_text(table):
    view, rows = table
    keys = [c.key for c in view.table.cols]
    snr = keys.index("snr_mean")
    view.sortByColumn(snr, Qt.SortOrder.DescendingOrder)
    # by the number: 380 > 150 > 57.3 > 21.5 (as text "57.3" would sort above "380")
    assert [r.snr_mean for r in view.shown_rows()] == [380.0, 150.0, 57.3, 21.5]
    view.sortByColumn(keys.index("ratio"), Qt.SortOrder.AscendingOrder)
    assert [r.snr_mean / r.model_snr["expected_eq4"] for r in view.shown_rows()] == sorted(
        r.snr_mean / r.model_snr["expected_eq4"] for r in rows
    )


def test_copy_puts_the_report_csv_of_the_rows_shown_on_the_clipboard(table):
    view, rows = table
    keys = [c.key for c in view.table.cols]
    view.sortByColumn(keys.index("lrf"), Qt.SortOrder.DescendingOrder)
    assert view.copy_csv() == 4
    parsed = list(csv.DictReader(io.StringIO(QApplication.clipboard().text())))
    assert tuple(parsed[0]) == CSV_COLUMNS  # the report's columns
    assert [float(p["lrf_range_m"]) for p in parsed] == [508.0, 508.0, 126.0, 126.0]
    # full precision, read back to the same number
    want = {(r.camera, r.stop): r for r in rows}
    for p in parsed:
        r = want[(p["camera"], int(p["stop"]))]
        assert float(p["snr_mean"]) == r.snr_mean
        assert float(p["model_small"]) == r.model_snr["small"]
        assert float(p["ratio_small"]) == pytest.approx(r.snr_mean / r.model_snr["small"])
    view.selectRow(0)  # a selection copies only what is selected
    assert view.copy_csv() == 1
    one = list(csv.DictReader(io.StringIO(QApplication.clipboard().text())))
    assert [(p["camera"], p["stop"]) for p in one] == [(parsed[0]["camera"], parsed[0]["stop"])]
