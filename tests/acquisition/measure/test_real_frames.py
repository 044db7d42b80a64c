"""Eq. (4) peak search on real thermal drone frames (shared data, 8-bit AGC'd video frames).

frames.csv gives MATLAB's 1-based bbox (x, y = top-left corner, w, h; PROVENANCE.md): the
zero-based box spans columns x-1 .. x-1+w and rows y-1 .. y-1+h (pixel edges).
"""

from __future__ import annotations

import csv

import cv2
import pytest

from snrmon.acquisition.measure.peak_snr import measure_peak_snr

# IR_DRONE_151 (the smallest drone in the set, 2x2 hot pixels at DN 32) hovers 3-4 rows above
# a treeline that is brighter (DN 46-144) in the AGC'd video: the brightest pixel of an 11x11
# window then lands on the treeline, as the paper's brightest-pixel rule would. There the
# operator must click closer and use a small window (the tracker issue gates such confusers).
CONFUSED_BY_TREELINE = {"IR_DRONE_151"}


def _rows(shared_data):
    folder = shared_data / "ir_small_targets" / "frames"
    with open(folder / "frames.csv", newline="") as fh:
        for row in csv.DictReader(fh):
            image = cv2.imread(str(folder / row["file"]), cv2.IMREAD_UNCHANGED)
            assert image is not None and image.ndim == 2, row["file"]
            x, y, w, h = (float(row[k]) for k in "xywh")
            yield row, image, (x - 1.0, y - 1.0, w, h)


def _inside(peak_x: int, peak_y: int, box) -> bool:
    left, top, w, h = box
    return left - 0.5 <= peak_x <= left + w - 0.5 and top - 0.5 <= peak_y <= top + h - 0.5


def test_all_twelve_frames_present(shared_data):
    assert len(list(_rows(shared_data))) == 12


@pytest.mark.parametrize("offset", [(0, 0), (3, 0), (-3, 0), (0, 3), (0, -3), (3, 3), (-3, -3)])
def test_peak_lands_on_labelled_drone_for_clicks_within_3px(shared_data, offset):
    checked = 0
    for row, image, box in _rows(shared_data):
        if row["clip"] in CONFUSED_BY_TREELINE:
            continue
        left, top, w, h = box
        at = (round(left + (w - 1) / 2 + offset[0]), round(top + (h - 1) / 2 + offset[1]))
        result = measure_peak_snr(image, at)
        assert _inside(result.peak_x, result.peak_y, box), (row["file"], at, result)
        assert result.snr > 0
        checked += 1
    assert checked == 10


def test_smallest_drone_needs_close_click_and_small_window(shared_data):
    for row, image, box in _rows(shared_data):
        if row["clip"] not in CONFUSED_BY_TREELINE:
            continue
        left, top, w, h = box
        cx, cy = left + (w - 1) / 2, top + (h - 1) / 2
        for ox in (-1, 0, 1):
            for oy in (-1, 0, 1):
                at = (round(cx + ox), round(cy + oy))
                result = measure_peak_snr(image, at, search_px=5)
                assert _inside(result.peak_x, result.peak_y, box), (row["file"], at, result)


def test_saturated_drones_are_flagged_at_255(shared_data):
    flagged = 0
    for _row, image, box in _rows(shared_data):
        left, top, w, h = box
        result = measure_peak_snr(image, (round(left + (w - 1) / 2), round(top + (h - 1) / 2)))
        assert ("saturated" in result.flags) == (result.peak >= 255)
        flagged += "saturated" in result.flags
    assert flagged >= 1
