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
