"""PSF/PVF: closed forms, two independent Airy methods, the paper's values."""

import math

import numpy as np
import pytest
from scipy.integrate import dblquad
from scipy.special import erf

from snrmon.model.psf import AiryGaussianPsf, AiryPsf, GaussianPsf, TabulatedMtfPsf
from snrmon.model.pvf import (
    average_pvf,
    average_pvf_spatial,
    average_pvf_vs_target_sigma,
    ensquared_energy,
    pixel_energy_fractions,
    solve_blur_sigma,
)

MW_MONO = AiryPsf.monochromatic(2.3, 8.0, 4.35)
MW_POLY = AiryPsf.polychromatic(2.3, 8.0, (3.45, 5.25))
LW_MONO = AiryPsf.monochromatic(1.25, 17.0, 10.0)
LW_POLY = AiryPsf.polychromatic(1.25, 17.0, (8.0, 12.0))


def _gauss_pvf_by_quadrature(sigma, ff):
    """Average over centre phases of the erf fraction, by 2-D adaptive quadrature."""
    h = math.sqrt(ff) / 2

    def frac(c):
        return 0.5 * (
            erf((h - c) / (sigma * math.sqrt(2))) - erf((-h - c) / (sigma * math.sqrt(2)))
        )

    one_d = dblquad(lambda y, x: frac(x), -0.5, 0.5, 0, 1, epsabs=1e-13)[0]
    return one_d**2


@pytest.mark.parametrize(("sigma", "ff"), [(0.8, 0.8), (0.3, 1.0), (1.183, 0.8), (0.5, 0.5)])
def test_gaussian_average_pvf_matches_erf_quadrature_and_spatial_method(sigma, ff):
    ref = _gauss_pvf_by_quadrature(sigma, ff)
    assert average_pvf(GaussianPsf(sigma), ff) == pytest.approx(ref, abs=1e-4)
    assert average_pvf_spatial(GaussianPsf(sigma), ff) == pytest.approx(ref, abs=1e-4)
    # the OTF route (used for non-Gaussian PSFs) agrees with the closed form too
    tab = TabulatedMtfPsf(
        tuple(np.linspace(0, 1.3 / sigma, 4001)),
        tuple(np.exp(-2 * math.pi**2 * sigma**2 * np.linspace(0, 1.3 / sigma, 4001) ** 2)),
    )
    assert average_pvf(tab, ff) == pytest.approx(ref, abs=1e-4)


def test_gaussian_ensquared_energy_closed_form():
    s, ff = 0.8, 0.8
    ref = erf(math.sqrt(ff) / 2 / (s * math.sqrt(2))) ** 2
    assert ensquared_energy(GaussianPsf(s), ff) == pytest.approx(ref, abs=1e-12)


@pytest.mark.parametrize(("psf", "ff"), [(MW_MONO, 0.8), (LW_MONO, 0.9), (MW_MONO, 1.0)])
def test_airy_pvf_two_independent_methods_agree(psf, ff):
    assert average_pvf(psf, ff) == pytest.approx(average_pvf_spatial(psf, ff), abs=1e-3)
    assert abs(average_pvf(psf, ff) - average_pvf_spatial(psf, ff)) < 1e-6


def test_paper_and_physics_notes_values():
    # independently computed (frequency- and spatial-domain integration; paper: 0.25 MWIR, 0.45 LWIR
    # diffraction limited)
    assert average_pvf(MW_MONO, 0.8) == pytest.approx(0.2624, abs=5e-4)
    assert ensquared_energy(MW_MONO, 0.8) == pytest.approx(0.3271, abs=5e-4)
    assert average_pvf(MW_POLY, 0.8) == pytest.approx(0.2654, abs=5e-4)
    assert average_pvf(LW_MONO, 0.9) == pytest.approx(0.4656, abs=5e-4)
    assert ensquared_energy(LW_MONO, 0.9) == pytest.approx(0.6912, abs=5e-4)
    assert average_pvf(LW_POLY, 0.9) == pytest.approx(0.4666, abs=5e-4)
    assert average_pvf(MW_MONO, 1.0) == pytest.approx(0.3148, abs=5e-4)
    assert average_pvf(GaussianPsf(0.8), 0.8) == pytest.approx(0.1602, abs=1e-4)
    assert average_pvf(AiryGaussianPsf(MW_POLY, 0.8), 0.8) == pytest.approx(0.1048, abs=1e-3)
    assert 0.25 * 0.9 < average_pvf(MW_POLY, 0.8) < 0.25 * 1.1
    assert 0.45 * 0.9 < average_pvf(LW_POLY, 0.9) < 0.45 * 1.1


def test_sigma_08_cannot_give_0082_and_the_solver_finds_the_blur_that_does():
    assert average_pvf(GaussianPsf(0.8), 0.8) > 0.15  # the paper's inconsistency
    s = solve_blur_sigma(0.082, 0.8)
    assert s == pytest.approx(1.183, abs=2e-3)
    assert average_pvf(GaussianPsf(s), 0.8) == pytest.approx(0.082, abs=1e-9)
    s2 = solve_blur_sigma(0.082, 0.8, base_psf=MW_POLY)
    assert s2 == pytest.approx(0.968, abs=3e-3)
    with pytest.raises(ValueError, match="cannot be reached"):
        solve_blur_sigma(0.5, 0.8, base_psf=MW_POLY)


def test_relative_drop_with_target_size_matches_paper_with_sigma_08():
    g = GaussianPsf(0.8)
    p0 = average_pvf(g, 0.8)
    for d, paper in ((1.0, 0.062), (0.5, 0.076), (0.25, 0.080)):
        assert average_pvf(g, 0.8, d / 2) / p0 == pytest.approx(paper / 0.082, abs=0.01)


def test_vectorised_pvf_table_matches_direct_values():
    s = np.array([0.0, 0.1, 0.37, 0.5])
    for psf in (MW_POLY, GaussianPsf(1.2), AiryGaussianPsf(MW_POLY, 0.4)):
        direct = [average_pvf(psf, 0.8, x) for x in s]
        assert np.allclose(average_pvf_vs_target_sigma(psf, 0.8, s), direct, atol=2e-6)


def _phase_average(psf, ff, st, n=12):
    x, w = np.polynomial.legendre.leggauss(n)
    x, w = 0.5 * x, 0.5 * w
    total = 0.0
    for xi, wi in zip(x, w, strict=True):
        for yj, wj in zip(x, w, strict=True):
            f = pixel_energy_fractions(psf, xi, yj, fill_factor=ff, target_sigma_px=st)
            total += wi * wj * f[3, 3]
    return total


@pytest.mark.parametrize(
    ("psf", "ff", "st"),
    [
        (GaussianPsf(1.183), 0.8, 0.0),
        (GaussianPsf(0.8), 0.8, 0.3),
        (MW_POLY, 0.8, 0.0),
        (LW_POLY, 0.9, 0.2),
        (AiryGaussianPsf(MW_POLY, 0.5), 0.8, 0.1),
    ],
)
def test_pixel_fractions_average_to_the_average_pvf(psf, ff, st):
    assert _phase_average(psf, ff, st) == pytest.approx(average_pvf(psf, ff, st), abs=2e-5)


def test_pixel_fractions_geometry():
    f = pixel_energy_fractions(MW_POLY, 0.3, -0.2, fill_factor=0.8)
    assert f.shape == (7, 7)
    # centroid right (+x) and up (-y): more energy in column 4 than 2, row 2 than 4
    assert f[3, 4] > f[3, 2] and f[2, 3] > f[4, 3]
    centred = pixel_energy_fractions(MW_POLY, 0.0, 0.0, fill_factor=0.8)
    assert centred[3, 3] == pytest.approx(ensquared_energy(MW_POLY, 0.8), abs=1e-5)
    assert np.allclose(centred, centred.T, atol=1e-9) and np.allclose(centred, centred[::-1])
    g = pixel_energy_fractions(GaussianPsf(0.7), 0.1, 0.4, fill_factor=1.0, half_size_px=6)
    assert g.sum() == pytest.approx(1.0, abs=1e-9)


def test_bad_inputs_are_refused():
    with pytest.raises(ValueError, match="fill factor"):
        average_pvf(GaussianPsf(1.0), 1.5)
    with pytest.raises(ValueError, match="sigma"):
        GaussianPsf(-0.5)  # sigma 0 is a delta function (tests/model/test_eq4_narrow_psf.py)
    with pytest.raises(ValueError, match="MTF"):
        TabulatedMtfPsf((0.0, 0.5), (0.9, 0.1))
