"""The compiled per-frame analysis equals the NumPy/OpenCV code it replaced, bit for bit.

Each compiled routine is run against its reference (the code at the branch point, kept in
``tests/reference``, or NumPy itself) on seeded random scenes built to reach every branch: an
unresolved and a resolved drone, a sloping sky (the plane fit), clutter beside the drone,
plateaus of equal pixels, integer and float frames, NaN and infinite pixels, windows cut by the
image's edge. Equality is of the repr (a float's every bit, and its type).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from numba import njit

from snrmon.acquisition.measure.background import background_stats
from snrmon.acquisition.measure.blob import BlobConfig, analyse_blob
from snrmon.acquisition.measure.jit import median32, pairwise_sum32, pairwise_sum64
from snrmon.acquisition.measure.local_sky import median
from snrmon.acquisition.measure.peak_snr import (
    PeakSnrConfig,
    PeakSnrMeter,
    background_of,
    measure_core,
    pixel_of,
    result_at,
    sequential_pass,
)
from snrmon.acquisition.measure.rim_kernel import rim_background, rim_stats
from snrmon.acquisition.measure.target_snr import _excesses, _rect_rim, rim_excess
from snrmon.acquisition.track.search import brightest_in, clip_box
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
        s32 = pairwise_sum32(b, 0, n)  # a float32 value (numba hands it back as a float)
        assert s32 == float(b.sum()) and float(np.float32(s32)) == s32
        lo = int(rng.integers(0, n))  # a run inside the array, as the segmentation sums rows
        assert repr(pairwise_sum64(a, lo, n - lo)) == repr(float(a[lo:].sum()))
        assert pairwise_sum32(b, lo, n - lo) == float(b[lo:].sum())


def test_median_is_local_skys():
    rng = np.random.default_rng(8)
    for _ in range(400):
        n = int(rng.integers(1, 300))
        a = (rng.standard_normal(n) * 10.0 ** rng.integers(-3, 5)).astype(np.float32)
        if rng.random() < 0.3:
            a = np.round(a) + np.float32(0.0)  # ties (no -0.0: blob_kernel.window_stats)
        if rng.random() < 0.2:  # 8-bit video: a few levels, mostly equal
            a = rng.integers(0, 4, n).astype(np.float32)
        assert repr(median32(a.copy(), n)) == repr(median(a))


def _old_brightest_in(frame, box):
    """search.brightest_in at the branch point."""
    b = clip_box(box, frame.shape)
    if b is None:
        return None
    x0, y0, x1, y1 = b
    win = frame[y0 : y1 + 1, x0 : x1 + 1]
    if win.dtype.kind == "f":
        if not np.isfinite(win).any():
            return None
        win = np.where(np.isnan(win), -np.inf, win)
    i = int(np.argmax(win))
    w = x1 - x0 + 1
    return x0 + i % w, y0 + i // w


@pytest.mark.parametrize("kind", KINDS)
def test_brightest_in_equals_the_numpy_reference(kind):
    rng = np.random.default_rng(100 + len(kind))
    for _ in range(300):
        frame, _ = scene(rng, kind)
        if rng.random() < 0.2:
            frame = np.round(frame / 50) * 50 if frame.dtype.kind == "f" else frame // 50
        if kind == "float32_bad" and rng.random() < 0.2:
            frame[:10, :10] = rng.choice([np.nan, -np.inf, np.inf])
        x0, y0 = int(rng.integers(-5, 70)), int(rng.integers(-5, 60))
        box = (x0, y0, x0 + int(rng.integers(0, 15)), y0 + int(rng.integers(0, 15)))
        assert brightest_in(frame, box) == _old_brightest_in(frame, box)


@pytest.mark.parametrize("kind", KINDS)
def test_wing_excesses_equal_the_numpy_sums(kind):
    rng = np.random.default_rng(200 + len(kind))
    exact = 0
    for _ in range(200):
        frame, (px, py) = scene(rng, kind)
        r = int(rng.integers(1, 6))
        rect = (px - r, py - r, px + r + int(rng.integers(0, 3)), py + r)
        sigma = float(rng.choice([0.0, rng.uniform(0.1, 30)]))
        most = int(rng.integers(0, 10))
        got = _excesses(frame, rect, sigma, most)
        with np.errstate(invalid="ignore"):
            want = [rim_excess(frame, rect, sigma, k) for k in range(most + 1)]
        if got is None:
            continue
        got = got.tolist()
        exact += 1
        for k in range(most + 1):  # the decision reads up to the first NaN
            assert repr(got[k]) == repr(want[k])
            if not math.isfinite(want[k]):
                break
    assert exact > (100 if kind in ("uint16", "uint8", "float32") else -1)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("detrend", [False, True])
def test_rim_stats_equal_background_stats(kind, detrend):
    rng = np.random.default_rng(300 + len(kind) + detrend)
    for _ in range(200):
        frame, _ = scene(rng, kind)
        w, h = int(rng.integers(3, 40)), int(rng.integers(3, 40))
        x0, y0 = int(rng.integers(0, 70 - w + 1)), int(rng.integers(0, 60 - h + 1))
        ddof = int(rng.integers(0, 2))
        mask, dy, dx = _rect_rim(w, h)
        values = frame[y0 : y0 + h, x0 : x0 + w][mask].reshape(1, -1).astype(np.float64)
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            mean, std, grad = background_stats(values, dy, dx, detrend=detrend, ddof=ddof)
            got = rim_stats(frame[y0 : y0 + h, x0 : x0 + w], detrend, ddof)
            with_gradient = rim_background(frame[y0 : y0 + h, x0 : x0 + w], detrend, ddof)
        assert repr(got[:2]) == repr((float(mean[0]), float(std[0])))
        assert repr(float(np.hypot(got[2], got[3]))) == repr(float(grad[0]))
        assert got[4] == values.shape[1]
        assert repr(with_gradient) == repr((*got[:2], float(grad[0]), got[4]))


def test_compiled_hypot_is_numpys():
    """The gradient's hypot compiled (the C library's) is NumPy's, bit for bit, over many
    magnitudes, zeros, infinities and NaN (Python's own math.hypot is not)."""
    rng = np.random.default_rng(17)
    x = rng.standard_normal(20000) * 10.0 ** rng.integers(-300, 300, 20000)
    y = rng.standard_normal(20000) * 10.0 ** rng.integers(-300, 300, 20000)
    x[:6], y[:6] = [0.0, -0.0, np.inf, np.nan, 1e-320, 3.0], [0.0, 5.0, 1.0, 2.0, 1e-320, -np.inf]
    want = np.hypot(x, y)
    got = np.array([compiled_hypot(float(a), float(b)) for a, b in zip(x, y, strict=True)])
    assert repr(got.tolist()) == repr(want.tolist())


@njit
def compiled_hypot(a, b):
    return math.hypot(a, b)


def _numpy_eq4(frame, at, cfg, meter):
    """Eq. (4) of one frame through the NumPy reductions (the stack path's ``measure_core``),
    with ``meter``'s noise reference and running statistics, as the per-frame path was."""
    core = measure_core(frame[None], at[0], at[1], cfg)
    sequential_pass(core, cfg, reference=meter.reference, running=meter.running)
    return result_at(core, 0, background_of(cfg))


def _as_compared(m):
    return repr((m, m.flags, m.peak, m.bg_mean, m.bg_std, m.snr))


@pytest.mark.parametrize("kind", [*KINDS, "int16", "float16"])
def test_per_frame_eq4_equals_the_numpy_reductions(kind):
    """The compiled Eq. (4) of one frame (window's brightest pixel, the rim's statistics)
    against NumPy's, frame after frame with the contamination reference and running
    statistics carried along: points anywhere (windows and boxes cut by the edge), every
    window and box size, detrend, ddof, saturation levels; NaN, infinite and -0.0 pixels."""
    rng = np.random.default_rng(400 + len(kind))
    for _ in range(40):
        cfg = PeakSnrConfig(
            search_px=int(rng.choice([1, 3, 5, 11, 15])),
            box_px=int(rng.choice([3, 5, 7, 9])),
            detrend=bool(rng.random() < 0.4),
            ddof=int(rng.integers(0, 2)),
            saturation_dn=None if rng.random() < 0.7 else float(rng.uniform(100, 4000)),
        )
        compiled, reference = PeakSnrMeter(cfg), PeakSnrMeter(cfg)
        for _ in range(12):
            base = {"int16": "uint16", "float16": "float32"}.get(kind, kind)
            frame, (px, py) = scene(rng, base)
            if kind == "int16":
                frame = (frame.astype(np.int32) - 3000).clip(-32768, 32767).astype(np.int16)
            elif kind == "float16":
                frame = frame.astype(np.float16)
            if kind == "float32_bad" and rng.random() < 0.15:
                frame[py - 6 : py + 7, px - 6 : px + 7] = rng.choice([np.nan, np.inf, -np.inf])
            if rng.random() < 0.5:
                at = (px + float(rng.uniform(-3, 3)), py + float(rng.uniform(-3, 3)))
            else:  # anywhere, near the edges too
                at = (int(rng.integers(0, 70)), int(rng.integers(0, 60)))
            at = (min(max(at[0], 0), 69), min(max(at[1], 0), 59))
            with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
                want = _numpy_eq4(frame, pixel_of(at), cfg, reference)
            got = compiled.measure(frame, at)
            assert _as_compared(got) == _as_compared(want)
        assert compiled.snapshot() == reference.snapshot()


def _calibration(rng, shape=(60, 70), bad_share=0.0):
    from snrmon.acquisition.calibrate.calibration import Calibration

    resp = rng.uniform(0.5, 2.0, shape).astype(np.float32) * np.float32(1e-15)
    offset = rng.uniform(-500, 3000, shape).astype(np.float32)
    bad = (rng.random(shape) < bad_share).astype(np.uint8)
    zeros = np.zeros(shape, np.float32)
    return Calibration("mwir", (3.0, 5.0), 0.005, (290.0, 320.0), resp, offset, bad, zeros, zeros)


@pytest.mark.parametrize("dtype", [np.uint16, np.float32, np.float64])
def test_compiled_correction_equals_calibration_correct(dtype):
    from snrmon.acquisition.calibrate.kernels import correct_box

    rng = np.random.default_rng(400 + np.dtype(dtype).itemsize)
    for _ in range(60):
        cal = _calibration(rng)
        raw = rng.uniform(0, 16000, cal.shape).astype(dtype)
        ref = rng.normal(0, 5, cal.shape).astype(np.float32)
        y0, x0 = int(rng.integers(0, 50)), int(rng.integers(0, 60))
        y1, x1 = y0 + int(rng.integers(1, 11)), x0 + int(rng.integers(1, 11))
        for use_ref in (False, True):
            want = cal.correct(raw, (y0, y1, x0, x1))
            if use_ref:
                want = want - ref[y0:y1, x0:x1]
            out = np.zeros(cal.shape, np.float32)
            maps = (cal.offset_dn, cal.safe_responsivity, cal.mean_offset_dn, cal.mean_responsivity)
            correct_box(raw, y0, y1, x0, x1, *maps, ref, True, use_ref, out)
            assert out[y0:y1, x0:x1].tobytes() == want.tobytes()


def _old_sky_add(sky, frame, result):
    """SkyTemperature.add at the branch point (the sample, without keeping it)."""
    from snrmon.acquisition.calibrate.calibration import temperature_of
    from snrmon.acquisition.calibrate.sky_temperature import SkySample

    dy, dx, y, x = sky._region(result)
    rows, cols = dy + y, dx + x
    h, w = sky.calibration.shape
    if rows.min() < 0 or cols.min() < 0 or rows.max() >= h or cols.max() >= w:
        return None
    keep = sky.calibration.bad[rows, cols] == 0
    rows, cols = rows[keep], cols[keep]
    if rows.size < 2:
        return None
    cal = sky.calibration
    lq = (frame[rows, cols].astype(np.float64) - cal.offset_dn[rows, cols]) / (
        cal.responsivity[rows, cols]
    )
    mean_lq = float(lq.mean())
    temps = temperature_of(cal.band_um, lq, cal.qe_curve)
    return SkySample(
        0,
        mean_lq,
        float(temperature_of(cal.band_um, mean_lq, cal.qe_curve)),
        float(np.std(temps, ddof=1)),
        int(rows.size),
    )


def test_compiled_sky_sample_equals_the_numpy_reference():
    from snrmon.acquisition.calibrate.calibration import radiance_of
    from snrmon.acquisition.calibrate.sky_temperature import SkyTemperature
    from snrmon.acquisition.measure.peak_snr import BACKGROUND_EXTENT, BACKGROUND_RIM, PeakSnr

    rng = np.random.default_rng(500)
    finite = 0
    for i in range(200):
        cal = _calibration(rng, bad_share=float(rng.choice([0.0, 0.05, 0.9])))
        level = float(radiance_of(cal.band_um, rng.uniform(200, 330)))
        raw = (cal.offset_dn + cal.responsivity * np.float32(level)).astype(np.float32)
        raw = np.clip(raw + rng.normal(0, 3, cal.shape), 0, 65535).astype(np.uint16)
        rect = (5, 6, 5 + int(rng.integers(1, 9)), 6 + int(rng.integers(0, 9)))
        sky = SkyTemperature("mwir", cal, rect=rect if i % 4 == 0 else None)
        px, py = int(rng.integers(-2, 72)), int(rng.integers(-2, 62))
        ext = int(rng.integers(0, 12))
        method = BACKGROUND_EXTENT if rng.random() < 0.5 else BACKGROUND_RIM
        result = PeakSnr(px, py, 1.0, 0.0, 1.0, 1.0, frozenset(), method, ext, ext)
        want = _old_sky_add(sky, raw, result)
        got = sky.add(0, raw, result)
        assert repr(got) == repr(want)
        finite += got is not None and math.isfinite(got.temp_std_k)
    assert finite > 50


class _OldWingProfile:
    """target_snr.WingProfile at the branch point (a deque of lists, Python's sum)."""

    def __init__(self, frames=25, most=8, z=4.0, min_frames=5):
        from collections import deque

        self.most, self.z, self.min_frames = most, z, min_frames
        self._recent = deque(maxlen=frames)

    def growth(self, pixels, rect, sigma):
        now = [math.nan] * (self.most + 1)
        self._recent.append(now)
        for k in range(self.most + 1):
            now[k] = rim_excess(pixels, rect, sigma, k)
            if not math.isfinite(now[k]):
                return k
            past = [e[k] for e in self._recent if math.isfinite(e[k])]
            if len(past) < self.min_frames:
                if now[k] <= self.z:
                    return k
            elif sum(past) / len(past) <= self.z / math.sqrt(len(past)):
                return k
        return self.most

    def snapshot(self):
        return {"recent": [[None if math.isnan(v) else v for v in e] for e in self._recent]}


@pytest.mark.parametrize("kind", ["float32", "uint16", "float64"])
def test_wing_profile_decides_and_remembers_as_before(kind):
    from snrmon.acquisition.measure.target_snr import WingProfile

    rng = np.random.default_rng(600 + len(kind))
    for _ in range(4):
        frames, z = int(rng.integers(3, 30)), float(rng.uniform(1, 6))
        new, old = WingProfile(frames=frames, z=z), _OldWingProfile(frames=frames, z=z)
        ks = []
        for i in range(80):
            frame, (px, py) = scene(rng, kind)
            rect = (px - 3, py - 3, px + 3, py + 3)
            sigma = float(rng.uniform(0.5, 20))
            with np.errstate(invalid="ignore"):
                k = old.growth(frame, rect, sigma)
            assert new.growth(frame, rect, sigma) == k
            ks.append(k)
            if i % 20 == 19:  # a snapshot restored continues the same
                assert new.snapshot() == old.snapshot()
                again = WingProfile(frames=frames, z=z)
                again.restore(new.snapshot())
                new = again
        assert len(set(ks)) > 1


@pytest.mark.parametrize("dtype", [np.uint16, np.float32])
def test_track_noise_ring_equals_estimate_noise(dtype):
    from snrmon.acquisition.measure.noise import estimate_noise
    from snrmon.acquisition.measure.track_noise import TrackNoise, ring_pixels

    rng = np.random.default_rng(700 + np.dtype(dtype).itemsize)
    shape = (60, 70)
    for _ in range(40):
        region = int(rng.choice([9, 21, 41]))
        ddof = int(rng.integers(0, 2))
        noise = TrackNoise(shape, region_px=region, ddof=ddof, interval_s=1e-9)
        first = (rng.normal(1000, 20, shape)).astype(dtype)
        second = (rng.normal(1000, 20, shape)).astype(dtype)
        peak = (int(rng.integers(0, 70)), int(rng.integers(0, 60)))
        noise.update(first, 0, peak)
        noise.update(second, 1, (peak[0] + 3, peak[1]))  # the armed pixels, not the new peak's
        sel = ring_pixels(shape, peak, region, 7)
        if sel[0].size <= ddof + 1:
            assert noise.latest is None
            continue
        here, previous = second[sel].reshape(1, -1), first[sel].reshape(1, -1)
        assert repr(noise.latest) == repr(estimate_noise(here, previous, ddof=ddof))


def test_compiled_table_lookup_is_np_interp():
    from snrmon.acquisition.calibrate.calibration import temperature_table
    from snrmon.acquisition.calibrate.kernels import _temperature

    rng = np.random.default_rng(800)
    for band in ((3.0, 5.0), (8.0, 12.0)):
        t, table = temperature_table(band, ())
        x = np.concatenate(
            [
                rng.uniform(table[0] * 0.9, table[-1] * 1.1, 20000),
                table[rng.integers(0, table.size, 2000)],  # the nodes themselves
                [table[0], table[-1], np.nan, np.inf, -np.inf],
            ]
        )
        want = np.interp(x, table, t, left=np.nan, right=np.nan)
        j = 0
        got = np.empty_like(want)
        for i, v in enumerate(x):  # the search starts from the last index, as in sky_sample
            got[i], j = _temperature(v, table, t, j if i % 2 else int(rng.integers(-5, 30000)))
        assert got.tobytes() == want.tobytes()
