"""The Monte-Carlo band's quantiles from each range's draws sorted
(model/montecarlo.quantiles_by_column) against numpy's np.quantile, bit for bit."""

import numpy as np
import pytest

from snrmon.model.montecarlo import BAND_QUANTILES, quantiles_by_column


@pytest.mark.parametrize("n", [10, 11, 200, 201])
@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_band_is_np_quantile_bit_for_bit(n, seed):
    rng = np.random.default_rng(seed)
    draws = rng.lognormal(size=(n, 300)) * 10.0 ** rng.uniform(-5, 5, size=300)
    draws[:, :7] = draws[:1, :7]  # ties: every draw equal at some ranges
    for q in (BAND_QUANTILES, (0.0, 0.5, 1.0), (0.025, 0.975)):
        assert np.array_equal(quantiles_by_column(draws, q), np.quantile(draws, q, axis=0)), q


def test_a_nan_draw_gives_nan_as_np_quantile_does():
    draws = np.random.default_rng(3).normal(size=(50, 4))
    draws[7, 2] = np.nan
    got = quantiles_by_column(draws, BAND_QUANTILES)
    assert np.array_equal(got, np.quantile(draws, BAND_QUANTILES, axis=0), equal_nan=True)
    assert np.isnan(got[:, 2]).all() and np.isfinite(got[:, [0, 1, 3]]).all()
