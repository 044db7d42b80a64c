"""Rim and rectangle geometry, rectangle parsing, and the least-squares plane detrend."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.measure.background import (
    background_stats,
    detrended,
    parse_rect,
    rect_offsets,
    rim_offsets,
    validate_rect,
)


def test_rim_of_7x7_is_24_outer_pixels_in_row_major_order():
    dy, dx = rim_offsets(7)
    assert len(dy) == 24
    assert np.all(np.maximum(abs(dy), abs(dx)) == 3)
    assert len(set(zip(dy.tolist(), dx.tolist(), strict=True))) == 24
    order = (dy + 3) * 7 + (dx + 3)
    assert np.all(np.diff(order) > 0)
    assert len(rim_offsets(3)[0]) == 8 and len(rim_offsets(9)[0]) == 32
    with pytest.raises(ValueError, match="odd integer >= 3, got 4"):
        rim_offsets(4)


def test_rectangle_corners_are_inclusive():
    dy, dx = rect_offsets((2, 5, 4, 6))
    assert dy.size == 3 * 2
    assert dx.sum() == 0 and dy.sum() == 0
    assert parse_rect("2, 5,4,6") == (2, 5, 4, 6)
    for bad in ("1,2,3", "a,b,c,d", "1,2,3,4,5"):
        with pytest.raises(ValueError, match="X0,Y0,X1,Y1"):
            parse_rect(bad)
    assert validate_rect((0, 0, 9, 4), (5, 10)) == (0, 0, 9, 4)
    with pytest.raises(ValueError, match="leaves the 10x5 image"):
        validate_rect((0, 0, 10, 4), (5, 10))
    with pytest.raises(ValueError, match="X1 < X0"):
        validate_rect((3, 0, 2, 4), (5, 10))


@pytest.mark.parametrize("offsets", [rim_offsets(7), rect_offsets((0, 0, 9, 4))])
def test_plane_detrend_matches_least_squares(offsets):
    dy, dx = offsets
    rng = np.random.default_rng(2)
    values = 50 + 0.7 * dx - 1.3 * dy + rng.normal(0, 1.0, (5, dx.size))
    mean, std, gradient = background_stats(values, dy, dx, detrend=True, ddof=1)
    design = np.column_stack([np.ones(dx.size), dx, dy])
    for i in range(5):
        coef, *_ = np.linalg.lstsq(design, values[i], rcond=None)
        resid = values[i] - design @ coef
        assert std[i] == pytest.approx(resid.std(ddof=1), rel=1e-10)
        assert gradient[i] == pytest.approx(np.hypot(coef[1], coef[2]), rel=1e-10)
        assert mean[i] == pytest.approx(values[i].mean(), rel=1e-14)
        np.testing.assert_allclose(detrended(values[i : i + 1], dy, dx)[0], resid, atol=1e-10)
    _, raw_std, _ = background_stats(values, dy, dx, detrend=False)
    assert np.all(raw_std > std)


def test_clear_region_is_the_largest_band_clear_of_the_target():
    from snrmon.acquisition.measure.background import clear_region, overlaps, target_box

    shape = (40, 56)  # rows, columns
    box = target_box(shape, [(30, 20)], margin_px=20)
    assert box == (10, 0, 50, 39)  # clipped to the image
    # bands: above and below none; left 10 x 40, right 5 x 40
    assert clear_region(shape, box) == (0, 0, 9, 39)
    # a brute-force search over every rectangle clear of a box agrees on the area
    rng = np.random.default_rng(4)
    for _ in range(20):
        rows, cols = int(rng.integers(5, 12)), int(rng.integers(5, 12))
        x0, y0 = int(rng.integers(0, cols)), int(rng.integers(0, rows))
        ex = (x0, y0, int(rng.integers(x0, cols)), int(rng.integers(y0, rows)))
        best = 0
        for a in range(cols):
            for b in range(rows):
                for c in range(a + 1, cols):
                    for d in range(b + 1, rows):
                        if not overlaps((a, b, c, d), ex):
                            best = max(best, (c - a + 1) * (d - b + 1))
        got = clear_region((rows, cols), ex)
        area = 0 if got is None else (got[2] - got[0] + 1) * (got[3] - got[1] + 1)
        assert area == best
        assert got is None or not overlaps(got, ex)
    assert clear_region((10, 10), (0, 0, 9, 9)) is None


def test_clear_region_cropped_keeps_the_pixels_next_to_the_target():
    from snrmon.acquisition.measure.background import clear_region, target_box

    shape = (720, 1280)
    box = target_box(shape, [(640, 300)], margin_px=20)  # (620, 280, 660, 320)
    assert clear_region(shape, box) == (0, 321, 1279, 719)  # 1280 x 399 below it
    assert clear_region(shape, box, max_pixels=256 * 256) == (512, 321, 767, 576)
    # near the bottom: the band above it, its rows next to the target
    low = target_box(shape, [(640, 690)], margin_px=20)
    assert clear_region(shape, low, max_pixels=256 * 256) == (512, 414, 767, 669)
    # a thin band keeps its short side whole and spends the rest along it: 50 rows x 1310
    thin = target_box((50, 5000), [(100, 25)], margin_px=20)
    assert clear_region((50, 5000), thin, max_pixels=256 * 256) == (121, 0, 1430, 49)
