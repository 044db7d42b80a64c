"""A GPS fix written as a /gps row reads back as the same fix (what a replay shows)."""

from __future__ import annotations

from datetime import UTC, datetime

import numpy as np
import pytest

from snrmon.acquisition.record import schema as S  # noqa: N812
from snrmon.acquisition.record.stream_rows import fix_from_row, gps_row
from snrmon.drivers.gps.fix import GpsFix


@pytest.mark.parametrize(
    "fix",
    [
        GpsFix(
            123_456_789,
            datetime(2026, 11, 22, 8, 30, 1, 250000, tzinfo=UTC),
            32.38123,
            -106.47912,
            1250.25,
            1228.5,
            2,
            14,
            0.6,
            "$GNGGA,083001.25,3222.87,N",
        ),
        GpsFix(5, None, None, None, None, None, 0, None, None, ""),  # no fix yet
    ],
)
def test_gps_row_round_trip(fix):
    row = np.array([gps_row(fix)], dtype=S.GPS_DTYPE)[0]
    assert fix_from_row(row) == fix
