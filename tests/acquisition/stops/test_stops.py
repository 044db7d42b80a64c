"""Range-stop detection on a simulated flight, manual marks, and the 100-frame stop summary."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snrmon.acquisition.measure.peak_snr import PeakSnr
from snrmon.acquisition.stops.detector import (
    StopConfig,
    StopDetector,
    detect_stops,
    frames_in_stop,
    summarise_stop,
)
from snrmon.drivers.rangefinder.reading import RangeReading, RangeStatus

PAPER_STOPS_M = (37.0, 126.0, 199.0, 336.0, 393.0, 451.0, 508.0)
S = 1_000_000_000


def _flight(speed_mps=5.0, hover_s=8.0, start_m=10.0):
    """Piecewise-linear nominal range: transit at ``speed_mps``, hover ``hover_s`` at each stop.
    Returns (range_of_t, [(t_start_s, t_end_s, range_m), ...])."""
    knots_t, knots_r, hovers = [0.0], [start_m], []
    t, r = 0.0, start_m
    for stop in PAPER_STOPS_M:
        t += abs(stop - r) / speed_mps
        knots_t.append(t)
        knots_r.append(stop)
        hovers.append((t, t + hover_s, stop))
        t += hover_s
        knots_t.append(t)
        knots_r.append(stop)
        r = stop
    t += 10.0  # fly on after the last stop
    knots_t.append(t)
    knots_r.append(r + 10.0 * speed_mps)
    return (lambda ts: np.interp(ts, knots_t, knots_r)), hovers, t


def _series(seed=0, lrf_hz=10.0, gps_hz=10.0, lrf_noise=0.3, gps_noise=0.6, outliers=True):
    range_of, hovers, duration = _flight()
    rng = np.random.default_rng(seed)
    t_lrf = np.arange(0.0, duration, 1.0 / lrf_hz) + rng.uniform(0, 0.01)
    r_lrf = range_of(t_lrf) + rng.normal(0.0, lrf_noise, t_lrf.size)
    if outliers:  # a few shots off a bird or the ground
        idx = rng.choice(t_lrf.size, 12, replace=False)
        r_lrf[idx] = rng.uniform(5.0, 900.0, idx.size)
    t_gps = np.arange(0.0, duration, 1.0 / gps_hz) + 0.05
    # GPS: a slow wander (random walk, ~0.3 m/s^0.5) plus white noise.
    wander = np.cumsum(rng.normal(0.0, 0.03, t_gps.size))
    r_gps = range_of(t_gps) + wander - wander.mean() + rng.normal(0.0, gps_noise, t_gps.size)
    lrf = [(int(t * S), float(r)) for t, r in zip(t_lrf, r_lrf, strict=True)]
    gps = [(int(t * S), float(r)) for t, r in zip(t_gps, r_gps, strict=True)]
    return lrf, gps, hovers


@pytest.mark.parametrize(
    "sources,seed", [(("lrf", "gps"), 0), (("lrf",), 1), (("gps",), 2), (("lrf", "gps"), 3)]
)
def test_finds_the_paper_stops(sources, seed):
    lrf, gps, hovers = _series(seed)
    stops = detect_stops(lrf if "lrf" in sources else (), gps if "gps" in sources else ())
    assert len(stops) == len(PAPER_STOPS_M), [(s.lrf_range_m, s.gps_range_m) for s in stops]
    for stop, (t0, t1, planned) in zip(stops, hovers, strict=True):
        assert not stop.manual
        # Start backdated to the hover's first steady reading; end at the first departing one.
        # Transit within the tolerance looks steady: 1 m (LRF) / 2.5 m (GPS) at 5 m/s = 0.2 s /
        # 0.5 s early, plus the 0.1 s reading interval and the noise.
        early_s = 0.35 if "lrf" in sources else 0.7
        assert t0 - early_s <= stop.t_start_ns / S <= t0 + 0.1
        assert stop.t_end_ns is not None
        assert t1 <= stop.t_end_ns / S <= t1 + 0.8
        assert stop.t_confirmed_ns - stop.t_start_ns >= 0.8 * 3.0 * S
        if "lrf" in sources:
            assert stop.lrf_range_m == pytest.approx(planned, abs=0.25)
        else:
            assert stop.lrf_range_m is None
        if "gps" in sources:
            assert stop.gps_range_m == pytest.approx(planned, abs=1.5)
    assert [s.index for s in stops] == list(range(len(PAPER_STOPS_M)))


def test_a_one_shot_per_second_rangefinder_finds_the_stops():
    lrf, _, hovers = _series(6, lrf_hz=1.0, outliers=False)
    rng = np.random.default_rng(6)
    lrf = [(t + int(rng.uniform(-0.2, 0.2) * S), r) for t, r in lrf]  # irregular trigger
    stops = detect_stops(lrf)
    assert len(stops) == len(PAPER_STOPS_M)
    for stop, (t0, _, planned) in zip(stops, hovers, strict=True):
        # A transit shot within tolerance + noise of the hover counts: up to ~0.5 s early.
        assert t0 - 0.5 <= stop.t_start_ns / S <= t0 + 1.3  # one shot per second
        assert stop.lrf_range_m == pytest.approx(planned, abs=0.4)


def test_a_short_pause_is_not_a_stop():
    # 2 s still, shorter than the 3 s steadiness: no stop.
    t = np.arange(0.0, 12.0, 0.1)
    r = np.interp(t, [0, 5, 7, 12], [100, 125, 125, 150])
    assert detect_stops([(int(a * S), float(b)) for a, b in zip(t, r, strict=True)]) == []
    # The same pause lasting 5 s is one.
    r = np.interp(t, [0, 4, 9, 12], [100, 120, 120, 135])
    stops = detect_stops([(int(a * S), float(b)) for a, b in zip(t, r, strict=True)])
    assert len(stops) == 1 and stops[0].lrf_range_m == pytest.approx(120.0)


def test_manual_marks_and_live_updates():
    det = StopDetector(StopConfig(steady_s=2.0))
    assert det.add_reading(RangeReading(0, None, RangeStatus.NO_TARGET)) is None
    # Moving: no stop; the operator marks one anyway.
    for i in range(20):
        det.add_range(i * S // 10, 50.0 + i * 0.5)
    m = det.mark_stop(2 * S)
    assert m.manual and m.index == 0 and m.t_end_ns is None and det.current == m
    for i in range(20, 40):  # still moving: a manual stop is not ended by the rule
        det.add_range(i * S // 10, 50.0 + i * 0.5)
    assert det.current is not None and det.current.manual
    assert det.current.lrf_range_m == pytest.approx(np.median(50.0 + np.arange(20, 40) * 0.5))
    ended = det.end_stop(4 * S)
    assert ended.t_end_ns == 4 * S and det.current is None
    # Then an automatic stop, and a second mark ends it where the operator says.
    for i in range(40, 80):
        det.add_range(i * S // 10, 80.0)
    auto = det.current
    assert auto is not None and not auto.manual and auto.index == 1
    second = det.mark_stop(8 * S)
    assert second.index == 2 and second.manual
    assert [(s.index, s.manual, s.t_end_ns) for s in det.stops] == [
        (0, True, 4 * S),
        (1, False, 8 * S),
        (2, True, None),
    ]


def test_bad_range_is_a_clear_error():
    det = StopDetector()
    with pytest.raises(ValueError, match="lrf range"):
        det.add_range(0, -3.0)
    with pytest.raises(ValueError, match="source"):
        det.add_range(0, 3.0, "radar")
    with pytest.raises(ValueError, match="steady_s"):
        StopConfig(steady_s=0.0)


def _frame(snr: float, flags=()) -> PeakSnr:
    return PeakSnr(5, 5, 100.0 + snr, 100.0, 1.0, snr, frozenset(flags))


def test_summary_takes_the_first_100_consecutive_valid_frames():
    rng = np.random.default_rng(5)
    snr = rng.normal(8.0, 1.0, 400)
    frames = [_frame(v) for v in snr]
    # Invalid frames break runs: at 10 (lost), 60 (contaminated), 150 (saturated).
    frames[10] = _frame(snr[10], {"lost"})
    frames[60] = _frame(snr[60], {"rim_contaminated"})
    frames[150] = _frame(snr[150], {"saturated"})
    frames[175] = _frame(snr[175], {"gps_cued"})  # valid: the track was cued, still a drone
    s = summarise_stop(frames)
    # First run of 100: 61..160 is broken at 150; 151..250 is the first complete one.
    assert s.complete and s.n_frames == 100 and s.first == 151
    assert s.frames == slice(151, 251)
    assert s.snr_mean == pytest.approx(snr[151:251].mean(), rel=1e-12)
    assert s.snr_std == pytest.approx(snr[151:251].std(ddof=1), rel=1e-12)


def test_summary_says_when_fewer_were_found():
    frames = [_frame(float(i)) for i in range(30)]
    frames[12] = _frame(math.nan, {"undefined"})
    s = summarise_stop(frames)
    assert not s.complete and s.n_frames == 17 and s.first == 13  # longest run 13..29
    assert s.snr_mean == pytest.approx(np.mean(np.arange(13, 30)))
    empty = summarise_stop([_frame(1.0, {"edge"})] * 5)
    assert empty.n_frames == 0 and empty.first is None and math.isnan(empty.snr_mean)


def test_frames_in_stop():
    lrf, gps, _ = _series(4)
    stop = detect_stops(lrf, gps)[2]
    t_frames = list(range(0, 200 * S, S // 30))  # a 30 fps camera
    sl = frames_in_stop(t_frames, stop)
    assert all(stop.contains(t) for t in t_frames[sl])
    assert not stop.contains(t_frames[sl.start - 1]) and not stop.contains(t_frames[sl.stop])


def test_a_stop_range_is_the_median_of_all_its_readings():
    """The open stop keeps its readings sorted (an hour-long hover must not sort 36,000 values
    on every reading); its reported range is still exactly ``statistics.median`` of them all."""
    import statistics

    rng = np.random.default_rng(11)
    det = StopDetector(StopConfig())
    ranges = 393.0 + rng.uniform(-0.4, 0.4, 2001)  # all within the 1 m tolerance: one stop
    for i, r in enumerate(ranges):
        det.add_range(i * S // 10, float(r), "lrf")
    stop = det.current
    assert stop is not None and stop.t_end_ns is None
    start = round(stop.t_start_ns * 10 / S)  # readings before the stop opened are not in it
    assert stop.lrf_range_m == statistics.median(ranges[start:].tolist())


def test_error_of_the_mean_counts_the_frames_autocorrelation():
    """White frames: sem = std / sqrt(N); a drifting, correlated series: larger (N_eff < N)."""
    from snrmon.acquisition.stops.detector import mean_error

    rng = np.random.default_rng(3)
    white = rng.standard_normal(100)
    assert mean_error(white) == pytest.approx(white.std(ddof=1) / 10, rel=0.25)
    walk = np.convolve(rng.standard_normal(130), np.ones(30) / 30, mode="valid")[:100]
    assert mean_error(walk) > 2.5 * walk.std(ddof=1) / 10
    assert np.isnan(mean_error([1.0, 2.0]))
    assert mean_error([5.0] * 10) == 0.0
