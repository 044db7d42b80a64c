"""The expected Eq. (4) reading (model/eq4.py, paper section 5) for a PSF much narrower than a
pixel, down to a delta function, against a Monte Carlo of the estimator written here.

The OTF grid of the pixel patterns cannot hold a Gaussian of sigma 0.001 px (its cutoff needs
128 / sigma frequencies; capped at 4096 they aliased at a 3.5-px period): the expected reading
was 3.7 (fill factor 0.8) where the estimator reads 8.8, and the 5 equal phase midpoints
weighted the step of a point leaving the active area by where they fell. Gaussian patterns
are closed forms now (model/footprint.py), and a narrow Gaussian's phases are cut at the
active edge (``phase_nodes``).

The Monte Carlo renders its own frames (the Gaussian's share of each pixel's active square
from the normal CDF, phases drawn uniform over the cell per frame, unit white noise) and runs
the paper's estimator itself: the brightest pixel of the 11 x 11 search window, the 24 rim
pixels of the 7 x 7 box around it, (peak - mean) / sample std, the mean over frames.
"""

import numpy as np
import pytest
from scipy.special import ndtr

from snrmon.model.eq4 import expected_eq4
from snrmon.model.footprint import average_pvf_square, pixel_patterns
from snrmon.model.psf import GaussianPsf

HALF = 9  # the frames' half size: the search window (5) and the box (3) around any peak


def _shares(sigma_px: float, fill_factor: float, centre_px: np.ndarray) -> np.ndarray:
    """(n, 2 HALF + 1): a Gaussian point's share of each pixel's active interval (1-D)."""
    a = 0.5 * np.sqrt(fill_factor)
    rel = np.arange(-HALF, HALF + 1)[None, :] - centre_px[:, None]
    if sigma_px == 0.0:  # a delta: all of it on the pixel whose active interval holds it
        return ((rel - a < 0) & (rel + a > 0)).astype(float)
    return ndtr((rel + a) / sigma_px) - ndtr((rel - a) / sigma_px)


def _monte_carlo(sigma_px, fill_factor, amplitude, frames=40_000, seed=3) -> tuple[float, float]:
    """Mean Eq. (4) reading over ``frames`` frames and its standard error."""
    rng = np.random.default_rng(seed)
    dx, dy = rng.uniform(-0.5, 0.5, (2, frames))
    img = (
        amplitude
        * _shares(sigma_px, fill_factor, dy)[:, :, None]
        * _shares(sigma_px, fill_factor, dx)[:, None, :]
    )
    img += rng.standard_normal(img.shape)
    search = img[:, HALF - 5 : HALF + 6, HALF - 5 : HALF + 6].reshape(frames, -1)
    r, c = np.divmod(search.argmax(axis=1), 11)
    r, c = r + HALF - 5, c + HALF - 5
    d = np.arange(-3, 4)
    rim_dy = np.r_[np.full(7, -3), np.full(7, 3), d[1:-1], d[1:-1]]
    rim_dx = np.r_[d, d, np.full(5, -3), np.full(5, 3)]
    n = np.arange(frames)[:, None]
    rim = img[n, r[:, None] + rim_dy, c[:, None] + rim_dx]
    snr = (img[np.arange(frames), r, c] - rim.mean(axis=1)) / rim.std(axis=1, ddof=1)
    return float(snr.mean()), float(snr.std() / np.sqrt(frames))


@pytest.mark.parametrize("fill_factor", [1.0, 0.8])
@pytest.mark.parametrize("sigma_px", [0.0, 0.001, 0.005, 0.05])
def test_a_narrow_psf_reads_what_the_estimator_reads(sigma_px, fill_factor):
    """Amplitude 10: within 1 % (the Monte Carlo's standard error is 0.1-0.2 %). With a fill
    factor of 1 a delta's light is always on one pixel: 10 x 1.034 (the 24-pixel std factor);
    with 0.8 a fifth of the phases lose it between the active areas."""
    mean, err = _monte_carlo(sigma_px, fill_factor, 10.0)
    assert err < 0.02
    expected = float(expected_eq4(GaussianPsf(sigma_px), fill_factor, 10.0))
    assert expected == pytest.approx(mean, rel=0.01)
    if sigma_px == 0.0 and fill_factor == 1.0:
        assert expected == pytest.approx(10.0 * 1.0342, rel=0.002)


def test_the_closed_form_patterns_average_to_the_otf_pvf():
    """A Gaussian's closed-form patterns (a 2-px square target), averaged over phases uniform in
    the cell, give the phase-averaged ensquared energy that the OTF integral gives."""
    psf, ff, d = GaussianPsf(0.6), 0.8, 2.0
    ph = (np.arange(40) + 0.5) / 40 - 0.5
    centre = pixel_patterns(psf, ff, ph, ph, half_size_px=0, target_square_px=d)[..., 0, 0]
    assert float(centre.mean()) == pytest.approx(average_pvf_square(psf, ff, d), rel=1e-3)


def test_a_delta_psf_has_no_otf_to_integrate():
    with pytest.raises(ValueError, match="delta-function PSF"):
        average_pvf_square(GaussianPsf(0.0), 0.8, 1.0)
    with pytest.raises(ValueError, match=">= 0"):
        GaussianPsf(-0.1)
