"""The HIL/demo stop table says which rows are not the paper's points, and why."""

from __future__ import annotations

from snrmon.rig.table import TABLE_HEADER, format_result, format_row


def _stop(**kw) -> dict:
    row = {
        "camera": "mwir",
        "planned_range_m": 336.0,
        "lrf_range_m": 336.0,
        "gps_range_m": 335.9,
        "n_frames": 100,
        "measured_snr_mean": 102.74,
        "measured_snr_std": 18.22,
        "truth_snr": 107.74,
        "model_snr": {
            "small": 124.51,
            "small_corrected": 33.75,
            "expected_eq4_rim": 35.1,
            "expected_eq4_extent": 35.2,
        },
        "measured_snr_mean_raw": 60.0,
        "resolved": False,
        "background": "rim",
        "expected_eq4_rule": "rim",
        "measured_over_model": 1.02,
        "truth_over_model": 0.99,
        "live_over_model": 1.01,
        "model_psf": "fitted PSF",
    }
    row.update(kw)
    return row


def test_unresolved_complete_row_is_a_point():
    line = format_row(_stop())
    assert line.split()[-1] == "point"
    assert "102.74" in line and "124.51" in line
    assert "-" not in line.split()[:-2]  # every number of this row was measured or modelled
    assert len(line.split()) == len(TABLE_HEADER.split())
    assert line.split()[-4:-2] == ["1.010", "fitted"]  # the console's ratio and its PSF


def test_resolved_short_row_is_marked_both():
    line = format_row(
        _stop(
            planned_range_m=37.0,
            n_frames=20,
            resolved=True,
            measured_snr_mean=2.47,
            truth_snr=720.8,
            background="extent_rim+rim",
        )
    )
    assert line.split()[-2:] == ["extent_rim+rim", "resolved,short"]
    assert " 20 " in line


def test_table_explains_the_marks_and_counts_drops():
    text = format_result(
        {
            "stops": [_stop(resolved=True, measured_snr_mean_raw=None, model_snr={"small": 9.0})],
            "frames": {
                "mwir": {"received": 600, "dropped": {"ring_overrun": 0}, "camera_gap": 0},
                "lwir": {"received": 300, "dropped": {"ring_overrun": 2}, "camera_gap": 5},
            },
        }
    )
    lines = text.splitlines()
    assert lines[0] == TABLE_HEADER
    assert lines[1].endswith("resolved")
    assert "'extent_rim': outside the segmented drone" in text
    assert lines[-2:] == [
        "mwir: 600 frames received, 0 dropped",
        "lwir: 300 frames received, 2 dropped, 5 never delivered by the camera",
    ]
    assert lines[1].split()[7] == "-"  # no raw (uncorrected) SNR without --fpn: not "nan"
    assert lines[1].split()[11:13] == ["-", "-"]  # no expected Eq. (4) in this row's model
    assert "nan" not in text
