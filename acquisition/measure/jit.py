"""Compiled helpers of the per-frame measurement (numba), bit-identical to the NumPy they replace.

The per-frame analysis (segmentation, Eq. 4's backgrounds, the wing profile) is a few hundred
small array operations a frame; each NumPy call on a few dozen pixels costs microseconds of
overhead, so it is compiled instead (``@njit(cache=True)``: the machine code is kept in
``__pycache__`` beside the module and loaded on later runs).

The kernels keep the interpreter lock (no ``nogil``): each runs for microseconds, and a thread
that releases the lock that briefly gets it back only when the thread that took it meanwhile
gives it up, a switch interval later (5 ms) if that thread is busy in Python. A live frame calls
some twenty kernels; with a busy thread beside it (the console painting, a model computation)
releasing the lock at each call cost the measurement thread up to 21 ms per twenty calls at
the 99th percentile, holding it 0.15 ms (``docs/engine.md``, "Where a live frame's time
goes").

Exactness is the contract: every compiled routine gives the bits the NumPy code gave.

- :func:`pairwise_sum64` / :func:`pairwise_sum32` are NumPy's own summation of a contiguous
  run (``sum`` of float arrays: blocks of 8 partial sums up to 128 values, halves beyond that,
  added to the reduction's initial 0), not a plain loop.
- :func:`median32` is :func:`snrmon.acquisition.measure.local_sky.median` (the mean of the two
  middle values added in float32, for an even count).
- Elementwise float32 arithmetic is done in float32 (NumPy's rule for a float32 array and a
  Python float: the float is rounded to float32 first), never contracted into fused
  multiply-adds (numba compiles without ``fastmath``).

Where no such guarantee is possible (a product sum that BLAS orders its own way), the callers
keep NumPy or prove the sum exact first (:func:`sum_is_exact`). ``math.hypot`` compiled is the C
library's ``hypot``, as NumPy's ``np.hypot`` is (``rim_kernel.rim_background``).
"""

from __future__ import annotations

import functools
import hashlib
import math
from pathlib import Path

import numpy as np
from numba import njit
from numba.core import caching

# Every module whose functions are kernels (compiled with :func:`kernel`).
_KERNEL_FILES = frozenset(
    str((Path(__file__).resolve().parents[1] / f).resolve())
    for f in (
        "measure/jit.py",
        "measure/blob_kernel.py",
        "measure/rim_kernel.py",
        "measure/track_noise.py",
        "calibrate/kernels.py",
    )
)


@functools.lru_cache(maxsize=1)
def _kernels_stamp() -> bytes:
    """One hash of all the kernel modules' sources."""
    h = hashlib.sha256()
    for path in sorted(_KERNEL_FILES):
        h.update(Path(path).read_bytes())
    return h.digest()


class _AllKernels:
    """A cache locator's freshness judged on all the kernel modules together: numba compiles
    the kernels a kernel calls, from other modules too, into its cached machine code, but
    judges a cache by the caller's own source file, so a changed helper (a median in this
    module) would be served stale to its callers in the others."""

    def get_source_stamp(self):
        return _kernels_stamp()

    @classmethod
    def from_function(cls, py_func, py_file):
        if str(Path(py_file).resolve()) not in _KERNEL_FILES:
            return None
        return super().from_function(py_func, py_file)


def _judge_all_kernels() -> None:
    """Put the locators above first in numba's list (the user's cache directory, the
    package's __pycache__, the user's cache: numba's order); other files keep numba's own."""
    impl = getattr(caching, "CacheImpl", None)
    classes = getattr(impl, "_locator_classes", None)
    if impl is None or not isinstance(classes, list):
        return  # another numba: its own judgement (a changed helper: clear the caches)
    ours = [
        type(f"AllKernels{base.__name__}", (_AllKernels, base), {})
        for base in (
            caching.UserProvidedCacheLocator,
            caching.InTreeCacheLocator,
            caching.UserWideCacheLocator,
        )
    ]
    impl._locator_classes = [*ours, *(c for c in classes if not issubclass(c, _AllKernels))]


_judge_all_kernels()


def kernel(fn):
    """``numba.njit`` as every kernel here uses it: cached on disk (judged on all the kernel
    modules' sources, :class:`_AllKernels`), holding the interpreter lock (module docstring)."""
    return njit(cache=True)(fn)


@kernel
def _block(a, lo, n, zero):
    # NumPy's pairwise_sum (loops_utils.h) of at most 128 values: sequential below 8, else
    # 8 partial sums combined as a tree, then the remainder; every partial sum in the type of
    # ``zero`` (float64 or float32, as NumPy sums a float64 or float32 array).
    if n < 8:
        res = zero
        for i in range(n):
            res += a[lo + i]
        return res
    r0, r1, r2, r3 = a[lo], a[lo + 1], a[lo + 2], a[lo + 3]
    r4, r5, r6, r7 = a[lo + 4], a[lo + 5], a[lo + 6], a[lo + 7]
    i = 8
    end = n - n % 8
    while i < end:
        r0 += a[lo + i]
        r1 += a[lo + i + 1]
        r2 += a[lo + i + 2]
        r3 += a[lo + i + 3]
        r4 += a[lo + i + 4]
        r5 += a[lo + i + 5]
        r6 += a[lo + i + 6]
        r7 += a[lo + i + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[lo + i]
        i += 1
    return res


@kernel
def _halves(n):
    # Beyond 128 values NumPy sums two halves, the first a multiple of 8.
    n2 = n // 2
    return n2 - n2 % 8


@kernel
def _pairwise(a, lo, n, zero):
    """NumPy's sum of ``a[lo:lo + n]`` (1-D): its pairwise sum (the halving done with an
    explicit stack: numba's cache cannot hold recursive functions), added to the reduction's
    initial 0, in the type of ``zero``."""
    if n <= 128:
        return zero + _block(a, lo, n, zero)
    los = np.empty(64, np.int64)
    ns = np.empty(64, np.int64)
    state = np.empty(64, np.int64)
    values = np.full(64, zero)
    sp, vp = 1, 0
    los[0], ns[0], state[0] = lo, n, 0
    while sp > 0:
        t = sp - 1
        m = ns[t]
        if m <= 128:
            values[vp] = _block(a, los[t], m, zero)
            vp += 1
            sp -= 1
        elif state[t] == 0:
            state[t] = 1
            los[sp], ns[sp], state[sp] = los[t], _halves(m), 0
            sp += 1
        elif state[t] == 1:
            state[t] = 2
            m2 = _halves(m)
            los[sp], ns[sp], state[sp] = los[t] + m2, m - m2, 0
            sp += 1
        else:
            values[vp - 2] = values[vp - 2] + values[vp - 1]
            vp -= 1
            sp -= 1
    return zero + values[0]


@kernel
def pairwise_sum64(a, lo, n):
    """NumPy's sum of ``a[lo:lo + n]`` (float64, 1-D)."""
    return _pairwise(a, lo, n, 0.0)


@kernel
def pairwise_sum32(a, lo, n):
    """The same in float32 (a float32 array's ``sum``: float32 partial sums)."""
    return _pairwise(a, lo, n, np.float32(0.0))


@kernel
def _select(a, n, k):
    """Moves the k-th smallest of ``a[:n]`` (finite) to ``a[k]``, the smaller ones before it:
    quickselect whose partitions have no branch on the data (every element swapped, the
    boundary moved by the comparison's 0 or 1: on noise half of a branching partition's
    comparisons are mispredicted), in two passes (below the pivot, then equal to it) so that
    the many equal values of 8-bit video do not make it quadratic."""
    lo, hi = 0, n - 1
    while hi > lo:
        p, q, r = a[lo], a[(lo + hi) // 2], a[hi]
        pivot = max(min(p, q), min(max(p, q), r))  # the median of the three
        store = lo
        for i in range(lo, hi + 1):  # a[lo:store] < pivot <= a[store:hi + 1]
            x = a[i]
            a[i] = a[store]
            a[store] = x
            store += x < pivot
        if k < store:
            hi = store - 1
            continue
        equal = store
        for i in range(store, hi + 1):  # a[store:equal] == pivot < a[equal:hi + 1]
            x = a[i]
            a[i] = a[equal]
            a[equal] = x
            equal += x <= pivot
        if k < equal:
            return
        lo = equal


@kernel
def median32(buf, n):
    """:func:`snrmon.acquisition.measure.local_sky.median` of ``buf[:n]`` (float32, finite, no -0.0:
    the k-th value is then the same whatever the selection), as a float64. Reorders
    ``buf[:n]``."""
    k = n // 2
    _select(buf, n, k)
    if n % 2:
        return np.float64(buf[k])
    below = buf[0]
    for i in range(1, k):
        below = max(below, buf[i])
    return np.float64(np.float32(below + buf[k])) / 2.0


@kernel
def pymax(a, b):
    """Python's ``max(a, b)`` (``a`` unless ``b > a``: NaN-ordered as Python orders it)."""
    return b if b > a else a


@kernel
def pymin(a, b):
    """Python's ``min(a, b)``."""
    return b if b < a else a


@kernel
def ulp32(x):
    """The float32 unit in the last place of a nonzero float32 value ``x`` (as float64)."""
    e = math.frexp(abs(x))[1]
    return math.ldexp(1.0, max(e - 24, -149))


@kernel
def sum_is_exact(bound, unit):
    """True when every sum of values that are multiples of ``unit`` with absolute sum at most
    ``bound`` is exact in float64 (so its order cannot change it)."""
    return bound * (1.0 + 1e-12) < unit * 4503599627370496.0  # 2**52


@kernel
def std_ddof(values, ddof):
    """``np.std(values, ddof=ddof)`` of a 1-D float64 array of more than ``ddof`` values."""
    n = values.size
    mean = pairwise_sum64(values, 0, n) / n
    sq = np.empty(n)
    for i in range(n):
        d = values[i] - mean
        sq[i] = d * d
    return math.sqrt(pairwise_sum64(sq, 0, n) / (n - ddof))


@kernel
def index_weighted_sum(sums, n):
    """sum(sums[k] * k) in float64, and whether that sum is exact whatever its order (its
    absolute sum checked against the last place of the smallest nonzero term)."""
    s = b = 0.0
    m = math.inf  # the smallest nonzero magnitude has the smallest last place
    for k in range(n):
        c = np.float64(sums[k])
        s += c * k
        b += abs(c) * k
        if c != 0.0 and k > 0:
            m = min(m, abs(c))
    return s, b == 0.0 or sum_is_exact(b, ulp32(m))
