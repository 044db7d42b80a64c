"""The expected Eq. (4) reading along a range grid (model/eq4.expected_eq4_by_rule: the targets'
patterns kept with their peak candidates and extent shapes, every size read in one pass)
against the same readings of each target's patterns on their own
(model/eq4.readings_of_patterns: the brightest pixel searched over the whole pattern, the
extent labelled), and the peak search on its candidates against a search of every pixel."""

import numpy as np
import pytest

from snrmon.model import eq4
from snrmon.model.eq4 import expected_eq4_by_rule, readings_of_patterns
from snrmon.model.footprint import phase_grid, pixel_patterns
from snrmon.model.presets import load_sensor
from snrmon.model.psf import GaussianPsf
from snrmon.model.snr import clear_caches

MW, LW = load_sensor("mwir"), load_sensor("lwir")
AMPLITUDES = np.array([0.0, 1e-3, 4.0, 60.0, 3e4])
SIZES_PX = np.array([0.0, 0.6, 4.0, 14.0])


@pytest.mark.parametrize(
    "psf, ff",
    [
        (MW.corrected_psf(), MW.fill_factor),
        (LW.corrected_psf(), LW.fill_factor),
        (GaussianPsf(0.7), 0.8),
    ],
    ids=["mwir", "lwir", "gaussian"],  # the Gaussian's flat tops are labelled
)
def test_one_pass_of_every_size_reads_what_each_pattern_reads_on_its_own(psf, ff):
    clear_caches()
    amp, size = (v.ravel() for v in np.meshgrid(AMPLITUDES, SIZES_PX))
    fast = expected_eq4_by_rule(psf, ff, amp, target_square_px=size)
    ph = phase_grid(5)
    for d in SIZES_PX:
        pats = pixel_patterns(psf, ff, ph, ph, half_size_px=eq4.MAX_HALF_PX, target_square_px=d)
        for a in AMPLITUDES:
            i = np.flatnonzero((amp == a) & (size == d))[0]
            for rule in ("rim", "target"):
                own = float(np.mean(readings_of_patterns(a * pats, background=rule)))
                assert fast[rule][i] == pytest.approx(own, rel=1e-9), (d, a, rule)


def _brightest_nearest_centre(pats: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The Eq. (4) peak of each pattern over every pixel: the brightest, ties to the pixel
    nearest the centre (the estimator's rule, written out)."""
    n = pats.shape[-1]
    k = np.arange(n) - n // 2
    dist = (k[:, None] ** 2 + k[None, :] ** 2).ravel()
    flat = pats.reshape(len(pats), -1)
    scale = 1.0 + np.abs(flat).max(axis=1)
    return np.divmod(np.argmax(flat - 1e-9 * scale[:, None] * dist, axis=1), n)


def test_the_peak_among_its_candidates_is_the_brightest_pixel_nearest_the_centre():
    rng = np.random.default_rng(7)
    n, c = 23, 11
    centre = (slice(None), slice(c - 3, c + 4), slice(c - 3, c + 4))  # where a peak may be
    bright = 0.1 * rng.normal(size=(40, n, n))
    bright[centre] += 5.0 + rng.normal(size=(40, 7, 7))
    dark = -np.abs(rng.normal(size=(5, n, n))) - 3.0
    dark[centre] += 3.0  # no pixel above zero: the least negative, near the centre
    plateau = np.zeros((3, n, n))
    plateau[:, 4:19, 5:20] = 1.0  # ties over a flat top, off centre by a column
    plateau[1, c, c + 3] = 1.0 + 1e-12  # barely brighter, three columns out
    plateau[2, c, c] = 1.0 - 1e-12  # the centre barely darker than its neighbours
    ph = phase_grid(5)
    airy = pixel_patterns(MW.corrected_psf(), 0.8, ph, ph, half_size_px=c).reshape(-1, n, n)
    pats = np.concatenate([bright, np.zeros((1, n, n)), dark, plateau, airy])
    for amp in (0.0, 1e-12, 1.0, 5e4):
        scaled = amp * pats
        one = np.ones(len(pats))
        max_abs, candidates = eq4._peak_candidates(pats)
        r, c, _ = eq4._peaks(eq4._Patterns.stack(pats), amp * one, max_abs, candidates, 11, 7)
        want_r, want_c = _brightest_nearest_centre(scaled)
        assert np.array_equal(r, want_r) and np.array_equal(c, want_c), amp
