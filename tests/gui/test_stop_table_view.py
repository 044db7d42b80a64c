"""The console's stop table cells."""

from snrmon.acquisition.stops.table import StopRow
from snrmon.gui.stop_table_view import row_texts


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
    cells = row_texts(row)
    assert cells[-1] == "ended short, resolved"
    assert cells[4] == "20" and cells[5] == "2.47" and cells[8] == "small 520.3"
    assert cells[7] == "extent_rim+rim"  # the background the stop was measured against
