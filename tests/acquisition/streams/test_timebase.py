"""The common clock and the interpolation of readings at frame times."""

from datetime import UTC, datetime

import numpy as np
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


class FakeHost:
    """A host monotonic clock the test moves by hand (ns)."""

    def __init__(self) -> None:
        self.t_ns = 10**12

    def __call__(self) -> int:
        return self.t_ns


def test_clock_map_slews_a_jumping_gps_time_and_never_steps_back():
    """A simulated receiver whose time jumps forward by 200 ms and back by 300 ms (a receiver
    reset, a leap handled late), with +-5 ms of receipt jitter, at 10 Hz for 10 minutes: the UTC
    stamped for each host time as it passes never decreases, every stretch runs at a rate within
    MAX_SLEW of 1, every stamp is still what the final map gives (a row changes only the
    future), and the map converges on the receiver's time."""
    from snrmon.acquisition.streams.timebase import MAX_SLEW, rows_array, utc_of_rows

    host = FakeHost()
    clock = ClockMap(now_ns=host)
    rng = np.random.default_rng(7)
    t0 = host.t_ns
    epoch0 = datetime(2019, 5, 14, 15, 0, tzinfo=UTC).timestamp() * 1e9

    def receiver_ns(t_ns: int) -> float:  # the receiver's time at host time t
        s = (t_ns - t0) / 1e9
        return epoch0 + (t_ns - t0) + (200e6 if s >= 30 else 0) - (300e6 if s >= 80 else 0)

    stamps_t, stamps_u = [], []
    for k in range(6000):
        host.t_ns = t0 + k * 100_000_000
        for j in range(10):  # frames between fixes, stamped as they arrive
            t = host.t_ns + j * 10_000_000
            stamps_t.append(t)
            stamps_u.append(clock.utc_ns(t))
        host.t_ns += 99_000_000
        u = receiver_ns(host.t_ns) + rng.normal(0.0, 5e6)
        before = clock.relabelled_ns
        clock.update_from_gps(host.t_ns, datetime.fromtimestamp(u / 1e9, tz=UTC))
        if clock.relabelled_ns != before:  # the first fix: what the writer does to its stamps
            stamps_u = [x + clock.relabelled_ns - before for x in stamps_u]
    t = np.array(stamps_t)
    u = np.array(stamps_u)
    assert np.all(np.diff(u) > 0)  # strictly increasing: never a step back
    rate = np.diff(u) / np.diff(t)
    assert rate.min() >= 1 - MAX_SLEW - 1e-6 and rate.max() <= 1 + MAX_SLEW + 1e-6
    # past stamps are what the map's rows (as a file records them) give
    assert np.array_equal(utc_of_rows(rows_array(clock.rows()), t), u)
    # the first fix relabelled the host's guess onto the receiver's time
    assert abs(u[0] - epoch0) < 20e6
    # the jump back was slewed at the capped rate (1 ms/s), not stepped: a second after it the
    # map is still more than 100 ms ahead, and 2 minutes on it has come 100+ ms closer
    after_back = (t - t0 >= 81e9) & (t - t0 < 200e9)
    err = u[after_back] - np.array([receiver_ns(x) for x in t[after_back]])
    assert err[0] > 100e6 and 0 < err[-1] < err[0] - 100e6
    # and converged: the last minute within 2 ms of the receiver
    last = t - t0 > 540e9
    err = u[last] - np.array([receiver_ns(x) for x in t[last]])
    assert np.abs(err).max() < 2e6
    residuals = [r.residual_ns for r in clock.rows()]
    assert max(residuals) > 150e6 and min(residuals) < -250e6  # each jump, as it was seen


def test_a_file_before_format_2_4_maps_its_host_rows_onto_the_first_fix():
    """/clock rows of a 2.3 file: the host's UTC (2026) until the first GPS row (2019). A time
    before that row maps with its offset, so a stop that began before the first fix and ended
    after it ends after it began, on the receiver's date."""
    from snrmon.acquisition.streams.timebase import utc_of_rows

    old = np.array(
        [
            (1_000_000_000, 1_796_000_000 * 10**9, b"host"),
            (5_000_000_000, 1_557_846_000 * 10**9, b"gps"),
        ],
        [("monotonic_ns", "<i8"), ("utc_ns", "<i8"), ("source", "S32")],
    )
    start, end = utc_of_rows(old, [3_000_000_000, 7_000_000_000])
    assert end - start == 4_000_000_000  # the session's own 4 s
    assert datetime.fromtimestamp(start / 1e9, tz=UTC).year == 2019
