"""Running mean / sample std of the last N finite SNR values, against numpy."""

from __future__ import annotations

import math

import numpy as np
import pytest

from snrmon.acquisition.measure.running_stats import RunningSnr


@pytest.mark.parametrize("window", [1, 2, 7, 100])
def test_matches_numpy_over_the_last_n_finite_values(window):
    rng = np.random.default_rng(window)
    values = rng.normal(10.0, 2.0, 1000)
    values[rng.random(1000) < 0.1] = np.nan
    values[5] = np.inf
    running = RunningSnr(window)
    kept: list[float] = []
    for v in values:
        accepted = running.push(v)
        assert accepted == math.isfinite(v)
        if accepted:
            kept.append(v)
        last = np.array(kept[-window:])
        assert running.count == len(last)
        if not kept:
            assert math.isnan(running.mean)
            continue
        assert running.mean == pytest.approx(last.mean(), rel=1e-12)
        if len(last) >= 2:
            assert running.std == pytest.approx(last.std(ddof=1), rel=1e-9, abs=1e-12)
        else:
            assert math.isnan(running.std)
    np.testing.assert_array_equal(running.values(), np.array(kept[-window:]))


def test_no_drift_on_a_long_run_with_a_large_offset():
    rng = np.random.default_rng(1)
    values = 1e6 + rng.normal(0.0, 1e-3, 200_000)
    running = RunningSnr(100)
    for v in values:
        running.push(v)
    assert running.mean == pytest.approx(values[-100:].mean(), rel=1e-15)
    assert running.std == pytest.approx(values[-100:].std(ddof=1), rel=1e-6)


def test_empty_clear_and_bad_window():
    running = RunningSnr(3)
    assert math.isnan(running.mean) and math.isnan(running.std) and not running.full
    for v in (1.0, 2.0, 4.0, 8.0):
        running.push(v)
    assert running.full and running.mean == pytest.approx(14.0 / 3.0)
    running.clear()
    assert running.count == 0 and math.isnan(running.mean)
    with pytest.raises(ValueError, match="positive integer, got 0"):
        RunningSnr(0)
