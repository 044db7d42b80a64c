"""The corrected frame corrected as it is read (acquisition/engine/lazy_frame.py) equals the
whole square corrected at once, on every pixel the measurement reads, and the engine measures
the same with it, bit for bit."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.calibrate.calibration import Calibration
from snrmon.acquisition.engine.camera_engine import CameraEngine
from snrmon.acquisition.engine.frame_correction import FrameCorrector
from snrmon.acquisition.engine.inputs import ApplyReference, SetRoi
from snrmon.acquisition.engine.lazy_frame import LazyFrame, read_box
from snrmon.acquisition.streams.ring import RingFrame

SHAPE = (200, 260)


def _calibration(bad_pixels: int, seed: int = 1) -> Calibration:
    rng = np.random.default_rng(seed)
    bad = np.zeros(SHAPE, np.uint8)
    if bad_pixels:
        where = np.random.default_rng(seed + 100)
        ys = where.integers(0, SHAPE[0], bad_pixels)
        xs = where.integers(0, SHAPE[1], bad_pixels)
        bad[ys, xs] = 1
    return Calibration(
        camera="test",
        band_um=(3.0, 5.0),
        t_int_s=0.001,
        temps_k=(283.0, 313.0),
        responsivity=rng.uniform(0.8, 1.2, SHAPE).astype(np.float32),
        offset_dn=rng.uniform(900, 1100, SHAPE).astype(np.float32),
        bad=bad,
        fit_rms_dn=np.zeros(SHAPE, np.float32),
        temporal_noise_dn=np.ones(SHAPE, np.float32),
    )


def _frames(n: int, seed: int = 2) -> np.ndarray:
    """A drone (a bright Gaussian spot) crossing noisy sky, seen through the calibration's
    pixels (offset + responsivity x radiance)."""
    cal = _calibration(0)
    rng = np.random.default_rng(seed)
    yy, xx = np.mgrid[0 : SHAPE[0], 0 : SHAPE[1]]
    out = np.empty((n, *SHAPE), np.uint16)
    for i in range(n):
        x, y = 60 + 2.5 * i, 80 + 1.0 * i
        spot = 400 * np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * 1.2**2))
        radiance = 1000 + spot + rng.normal(0, 8, SHAPE)
        out[i] = (cal.offset_dn + cal.responsivity * radiance).astype(np.uint16)
    return out


def _pair(cal, reference: bool):
    eager = FrameCorrector(SHAPE, 60, lazy=False)
    lazy = FrameCorrector(SHAPE, 60)
    offset = np.random.default_rng(3).normal(0, 3, SHAPE).astype(np.float32)
    summary = {"n_frames": 2, "first_counter": 0, "last_counter": 1, "spatial_std_dn": 3.0}
    for c in (eager, lazy):
        c.calibration = cal
        if reference:
            c.set_reference_offset(offset, summary)
    return eager, lazy


@pytest.mark.parametrize(
    ("bad_pixels", "reference"), [(0, False), (0, True), (40, False), (40, True), (None, True)]
)
def test_pixels_read_equal_the_whole_square_corrected(bad_pixels, reference):
    cal = None if bad_pixels is None else _calibration(bad_pixels)
    eager, lazy = _pair(cal, reference)
    frame = _frames(1)[0]
    rng = np.random.default_rng(4)
    for roi in [(30, 40), (130, 100), (255, 195)]:
        full = eager.apply(frame, roi)
        view = lazy.apply(frame, roi)
        assert isinstance(view, LazyFrame)
        x, y = roi
        for _ in range(30):
            y0 = int(rng.integers(max(y - 60, 0), min(y + 60, SHAPE[0])))
            x0 = int(rng.integers(max(x - 60, 0), min(x + 60, SHAPE[1])))
            y1 = min(y0 + int(rng.integers(1, 40)), y + 61)
            x1 = min(x0 + int(rng.integers(1, 40)), x + 61)
            np.testing.assert_array_equal(view[y0:y1, x0:x1], full[y0:y1, x0:x1])
            assert view[y0, x0] == full[y0, x0]
        rows = np.array([[y - 3, y - 1]]).clip(0, SHAPE[0] - 1)
        cols = np.array([[x, x]]).clip(0, SHAPE[1] - 1)
        np.testing.assert_array_equal(
            view[None][np.zeros((1, 1), int), rows, cols],
            full[None][np.zeros((1, 1), int), rows, cols],
        )


def test_read_box_names_the_rectangle_read_or_none():
    shape = (10, 20)
    assert read_box((slice(2, 5), slice(None)), shape) == (2, 5, 0, 20)
    assert read_box((3, -1), shape) == (3, 4, 19, 20)
    assert read_box((slice(None), slice(1, 4), slice(5, 9)), (1, *shape)) == (1, 4, 5, 9)
    assert read_box((np.array([0]), np.array([[2, 7]]), np.array([[3, 3]])), (1, *shape)) == (
        2,
        8,
        3,
        4,
    )
    assert read_box(np.ones(shape, bool), shape) is None
    assert read_box((slice(0, 10, 2), slice(None)), shape) is None
    assert read_box(Ellipsis, shape) is None


def test_an_index_of_another_kind_corrects_the_whole_square():
    eager, lazy = _pair(_calibration(0), reference=False)
    frame = _frames(1)[0]
    full = eager.apply(frame, (100, 100))
    view = lazy.apply(frame, (100, 100))
    sub = view[np.s_[40:161, 40:161][0], ...]  # an ellipsis: which rectangle is not told
    np.testing.assert_array_equal(sub[:, 40:161], full[40:161, 40:161])


def _engine(lazy: bool, cal) -> CameraEngine:
    engine = CameraEngine("test", SHAPE, window=10)
    engine.display_figures = False
    engine.set_calibration(cal)
    engine.corrector.lazy = lazy
    return engine


@pytest.mark.parametrize("bad_pixels", [0, 40])
def test_the_engine_measures_the_same_corrected_lazily(bad_pixels):
    cal = _calibration(bad_pixels)
    frames = _frames(40)
    outputs = []
    for lazy in (False, True):
        engine = _engine(lazy, cal)
        engine.post(SetRoi(60, 80))
        offset = np.random.default_rng(5).normal(0, 2, SHAPE).astype(np.float32)
        summary = {"n_frames": 2, "first_counter": 0, "last_counter": 1, "spatial_std_dn": 2.0}
        rows = []
        for i, frame in enumerate(frames):
            if i == 20:
                engine.post(ApplyReference(offset, summary))
            if lazy:  # whatever was not corrected this frame must never be read
                engine.corrector._buffer.fill(np.nan)
            m = engine.process(
                RingFrame(frame, i, i, i * 16_666_667, None, engine.name)
            ).measurement
            assert m is not None
            rows.append((repr(m.result), m.track_state, m.window_xy, m.snr_mean, m.snr_std))
        outputs.append(rows)
    assert outputs[0] == outputs[1]
    states = [r[1] for r in outputs[0]]
    assert states.count("tracking") > 30, states
