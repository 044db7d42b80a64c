"""Gauss-Legendre nodes by Newton's method (model/quadrature.py) against numpy's leggauss (an
eigenvalue problem) and against integrals known in closed form."""

import math

import numpy as np
import pytest

from snrmon.model.quadrature import gauss_legendre


@pytest.mark.parametrize("n", [1, 2, 3, 5, 8, 24, 48, 64, 96])
def test_the_nodes_and_weights_are_leggauss_within_rounding(n):
    x, w = gauss_legendre(n)
    x_np, w_np = np.polynomial.legendre.leggauss(n)
    np.testing.assert_allclose(x, x_np, rtol=0.0, atol=2.5e-16)  # 2 ulp of 1
    np.testing.assert_allclose(w, w_np, rtol=2e-12, atol=0.0)
    assert np.array_equal(x, -x[::-1]) and np.array_equal(w, w[::-1])
    assert np.all(np.diff(x) > 0)


@pytest.mark.parametrize("n", [24, 48, 96])
def test_they_integrate_what_gauss_legendre_integrates_exactly_to_rounding(n):
    x, w = gauss_legendre(n)
    # the even powers up to x^(2n - 2): exact for n nodes
    for k in range(n):
        assert float(w @ x ** (2 * k)) == pytest.approx(2.0 / (2 * k + 1), rel=1e-13), k
    assert float(w @ np.exp(x)) == pytest.approx(math.e - 1.0 / math.e, rel=1e-14)
    assert float(w @ (1.0 / (1.0 + x * x))) == pytest.approx(math.pi / 2.0, rel=1e-14)


def test_no_nodes_is_refused():
    with pytest.raises(ValueError, match="n >= 1"):
        gauss_legendre(0)
