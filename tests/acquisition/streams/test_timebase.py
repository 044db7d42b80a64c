"""The common clock and the interpolation of readings at frame times."""

from datetime import UTC, datetime

import pytest

from snrmon.acquisition.streams.history import ScalarHistory
from snrmon.acquisition.streams.timebase import ClockMap


def test_interpolated_range_matches_raw_readings_at_their_own_times():
    h = ScalarHistory()
    raw = [(1_000_000_000, 100.0), (1_100_000_000, 101.0), (1_300_000_000, 99.0)]
    for t, v in raw:
        h.append(t, v)
    for t, v in raw:
        assert h.value_at(t) == v
    assert h.value_at(1_050_000_000) == pytest.approx(100.5)
    assert h.value_at(1_200_000_000) == pytest.approx(100.0)


def test_stale_history_gives_no_value():
    h = ScalarHistory(max_gap_ns=500_000_000)
    h.append(0, 10.0)
    assert h.value_at(400_000_000) == 10.0
    assert h.value_at(600_000_000) is None
    assert ScalarHistory().value_at(0) is None


def test_out_of_order_reading_is_refused():
    h = ScalarHistory()
    h.append(10, 1.0)
    with pytest.raises(ValueError, match="older"):
        h.append(5, 2.0)


def test_clock_map_reanchors_on_gps_time():
    clock = ClockMap()
    utc = datetime(2019, 4, 16, 17, 30, 0, tzinfo=UTC)
    clock.update_from_gps(5_000_000_000, utc)
    assert clock.reference.source == "gps"
    assert clock.utc(6_500_000_000) == datetime(2019, 4, 16, 17, 30, 1, 500000, tzinfo=UTC)
