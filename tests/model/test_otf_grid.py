"""The Cartesian OTF grid (model/footprint.otf_grid: the radial OTF evaluated once per distinct
j^2 + k^2) against the definition evaluated at every grid point, and the PVF-by-size table
computed only as far as the sizes asked for need: the same values whatever was asked before."""

import math

import numpy as np
import pytest

from snrmon.model import footprint
from snrmon.model.footprint import average_pvf_square, otf_grid
from snrmon.model.presets import load_sensor
from snrmon.model.psf import AiryGaussianPsf, GaussianPsf, TabulatedMtfPsf, otf

MW, LW = load_sensor("mwir"), load_sensor("lwir")
PSFS = [
    MW.diffraction_psf(),
    LW.diffraction_psf(),
    AiryGaussianPsf(LW.diffraction_psf(), 0.45),
    GaussianPsf(0.7),
    TabulatedMtfPsf((0.0, 0.2, 0.5, 0.9), (1.0, 0.7, 0.3, 0.0)),
]


@pytest.mark.parametrize("psf", PSFS, ids=["mwir", "lwir", "lwir-blurred", "gauss", "table"])
def test_the_grid_is_the_otf_at_every_point_times_the_quadrant_weights(psf):
    period = 24.0
    f, m = otf_grid(psf, period)
    step = f[1] - f[0]
    mult = np.where(np.arange(f.size) == 0, 1.0, 2.0) * step
    fx, fy = np.meshgrid(f, f, indexing="ij")
    # each component inside its cutoff, as the grid takes it (an Airy's is 0 beyond)
    radius = np.hypot(fx, fy)
    direct = sum(w * np.where(radius < cut, fn(radius), 0.0) for w, fn, cut in psf.components())
    if isinstance(psf, AiryGaussianPsf):  # the blur's separable MTF on the Airy's grid
        direct = otf(psf.airy, radius) * np.exp(-2 * math.pi**2 * psf.sigma_px**2 * radius**2)
    np.testing.assert_allclose(m, direct * mult[:, None] * mult[None, :], rtol=1e-14, atol=1e-18)


@pytest.mark.parametrize("psf", [MW.corrected_psf(), LW.corrected_psf()], ids=["mwir", "lwir"])
def test_a_pvf_reads_the_same_from_a_partial_and_the_whole_table(psf):
    sizes = np.array([0.0, 0.3, 1.0, 2.5, 4.9])
    footprint._square_table.cache_clear()
    footprint._square_table_chunk.cache_clear()
    partial = average_pvf_square(psf, 0.8, sizes)
    assert footprint._square_table.cache_info().currsize == 1  # only the first chunks made
    # asked with a size past the table's end, the same sizes read from the whole table
    whole = average_pvf_square(psf, 0.8, np.append(sizes, 70.0))
    assert np.array_equal(whole[:-1], partial)
    assert float(whole[-1]) == pytest.approx(0.8 / 70.0**2, rel=0.02)
