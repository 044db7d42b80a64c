"""The compiled per-frame analysis equals the NumPy/OpenCV code it replaced, bit for bit.

Each compiled routine is run against its reference (the code at the branch point, kept in
``tests/reference``, or NumPy itself) on seeded random scenes built to reach every branch: an
unresolved and a resolved drone, a sloping sky (the plane fit), clutter beside the drone,
plateaus of equal pixels, integer and float frames, NaN and infinite pixels, windows cut by the
image's edge. Equality is of the repr (a float's every bit, and its type).
"""

from __future__ import annotations

import numpy as np
import pytest

from acquisition.measure.blob import BlobConfig, analyse_blob
from acquisition.measure.jit import median32, pairwise_sum32, pairwise_sum64
from acquisition.measure.local_sky import median
from tests.reference import blob_numpy


def scene(rng: np.random.Generator, kind: str, shape=(60, 70)) -> tuple[np.ndarray, tuple]:
    """A frame of ``kind`` and a drone position in it."""
    rows, cols = shape
    yy, xx = np.mgrid[0:rows, 0:cols]
    level = rng.uniform(-50, 5000)
    noise = rng.uniform(0.3, 30.0)
    img = level + noise * rng.standard_normal(shape)
    if rng.random() < 0.4:  # a sloping sky, sometimes steep
        img += rng.uniform(-3, 3) * noise * xx / 10 + rng.uniform(-3, 3) * noise * yy / 10
    px, py = rng.uniform(2, cols - 3), rng.uniform(2, rows - 3)
    width = rng.choice([0.5, 0.8, 1.5, 3.0, 6.0])
    amp = noise * rng.uniform(2, 200)
    img += amp * np.exp(-((xx - px) ** 2 + (yy - py) ** 2) / (2 * width**2))
    if rng.random() < 0.3:  # clutter: a second object or a bright band
        qx, qy = rng.uniform(0, cols), rng.uniform(0, rows)
        img += amp * rng.uniform(0.3, 2) * np.exp(-((xx - qx) ** 2 + (yy - qy) ** 2) / 8.0)
    if rng.random() < 0.2:
        img[: rng.integers(1, rows // 2)] += amp * rng.uniform(0.2, 1.5)
    if rng.random() < 0.15:  # a saturated plateau
        img = np.minimum(img, np.quantile(img, 0.995))
    if kind == "uint16":
        out = np.clip(np.round(img), 0, 65535).astype(np.uint16)
    elif kind == "uint8":
        out = np.clip(np.round((img - img.min()) / max(np.ptp(img), 1) * 255), 0, 255)
        out = out.astype(np.uint8)
    elif kind == "float64":
        out = img
    else:
        out = img.astype(np.float32)
        if kind == "float32_bad":
            for _ in range(rng.integers(1, 6)):
                bad = rng.choice([np.nan, np.inf, -np.inf, -0.0, 0.0])
                out[rng.integers(rows), rng.integers(cols)] = bad
    return out, (round(px), round(py))


KINDS = ["float32", "uint16", "uint8", "float64", "float32_bad"]


@pytest.mark.parametrize("kind", KINDS)
def test_analyse_blob_equals_the_numpy_reference(kind):
    rng = np.random.default_rng(sum(map(ord, kind)))
    configs = [BlobConfig(), BlobConfig(flatten=False), BlobConfig(min_half_px=3, ring_px=1)]
    compared = 0
    for _ in range(150):
        frame, (px, py) = scene(rng, kind)
        cfg = configs[int(rng.integers(len(configs)))]
        for _ in range(3):
            jitter = rng.integers(-4, 5, 2) if rng.random() < 0.7 else rng.integers(-30, 30, 2)
            seed = (int(np.clip(px + jitter[0], 0, 69)), int(np.clip(py + jitter[1], 0, 59)))
            kw = {}
            if rng.random() < 0.3:
                kw["min_half_px"] = int(rng.integers(3, 30))
            if rng.random() < 0.3:
                kw["centre_xy"] = (px, py)
            if rng.random() < 0.1:
                kw["sigma"] = float(rng.uniform(0.1, 20))
            want = blob_numpy.analyse_blob(frame, seed, cfg, **kw)
            got = analyse_blob(frame, seed, cfg, **kw)
            assert repr(got) == repr(want), (seed, kw)
            compared += want is not None
    assert compared > 300


def test_pairwise_sums_are_numpys():
    rng = np.random.default_rng(7)
    for _ in range(400):
        n = int(rng.integers(1, 2000))
        a = rng.standard_normal(n) * 10.0 ** rng.integers(-4, 8, n)
        assert repr(pairwise_sum64(a, 0, n)) == repr(float(a.sum()))
        b = a.astype(np.float32)
        assert pairwise_sum32(b, 0, n) == b.sum()


def test_median_is_local_skys():
    rng = np.random.default_rng(8)
    for _ in range(400):
        n = int(rng.integers(1, 300))
        a = (rng.standard_normal(n) * 10.0 ** rng.integers(-3, 5)).astype(np.float32)
        if rng.random() < 0.3:
            a = np.round(a) + np.float32(0.0)  # ties (no -0.0: blob_kernel.window_stats)
        assert repr(median32(a.copy(), n)) == repr(median(a))
