"""Gauss-Legendre quadrature on [-1, 1] (the band integrals of :mod:`snrmon.model.radiometry`,
the polar PVF integrals of :mod:`snrmon.model.pvf`).

The nodes are the roots of the Legendre polynomial P_n, found by Newton's method from
Tricomi's approximation cos(pi (k - 1/4) / (n + 1/2)) with P_n and its derivative from the
three-term recurrence; the weights are 2 / ((1 - x^2) P_n'(x)^2). Symmetrised and normalised
as ``numpy.polynomial.legendre.leggauss`` does, they agree with it within 2 ulp (nodes) and
2e-12 relative (weights, n <= 100; these integrate smooth functions within 1e-14, leggauss's
within 2e-13) (tests/model/test_quadrature.py). Not leggauss itself: it solves an eigenvalue
problem in LAPACK, whose threaded BLAS woke OpenBLAS's worker threads in the model's first
call; their spinning took a core for ~0.1 s after it, 40-70 ms of a first prediction's wall
time on a busy 2-core machine.
"""

from __future__ import annotations

import functools
import math

import numpy as np

_NEWTON_STEPS = 12  # quadratic convergence from Tricomi's guesses: 3-4 steps reach 1e-16


@functools.lru_cache(maxsize=16)
def gauss_legendre(n: int) -> tuple[np.ndarray, np.ndarray]:
    """``n`` Gauss-Legendre nodes on [-1, 1], ascending, and their weights (read-only)."""
    if n < 1:
        raise ValueError(f"Gauss-Legendre quadrature needs n >= 1 nodes, got {n}")
    k = np.arange(1, n + 1)
    x = np.cos(math.pi * (k - 0.25) / (n + 0.5))[::-1].copy()
    for _ in range(_NEWTON_STEPS):
        p_n, dp_n = _legendre(n, x)
        step = p_n / dp_n
        x -= step
        if np.max(np.abs(step)) < 1e-16:
            break
    _, dp_n = _legendre(n, x)
    w = 2.0 / ((1.0 - x * x) * dp_n * dp_n)
    # symmetric in x -> -x, the weights summing to 2, as numpy's leggauss makes them
    x = (x - x[::-1]) / 2.0
    w = (w + w[::-1]) / 2.0
    w *= 2.0 / w.sum()
    x.setflags(write=False)
    w.setflags(write=False)
    return x, w


def _legendre(n: int, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """P_n(x) and P_n'(x) by the recurrence j P_j = (2j - 1) x P_(j-1) - (j - 1) P_(j-2)."""
    p_prev, p = np.ones_like(x), x.copy()
    for j in range(2, n + 1):
        p_prev, p = p, ((2 * j - 1) * x * p - (j - 1) * p_prev) / j
    if n == 0:
        return np.ones_like(x), np.zeros_like(x)
    return p, n * (x * p - p_prev) / (x * x - 1.0)
