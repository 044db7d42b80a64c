"""The vectorised stack path equals the per-frame meter bit for bit (flags and state included)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from snrmon.acquisition.measure.peak_snr import PeakSnr, PeakSnrMeter
from snrmon.acquisition.measure.stack_snr import measure_stack


def _bits(r: PeakSnr) -> tuple:
    floats = np.array([r.peak, r.bg_mean, r.bg_std, r.snr], dtype=np.float64).tobytes()
    return (r.peak_x, r.peak_y, floats, r.flags)


@st.composite
def _cases(draw):
    n = draw(st.integers(1, 6))
    rows, cols = draw(st.integers(5, 18)), draw(st.integers(5, 18))
    kind = draw(st.sampled_from(["uint16", "uint8", "float64"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    hi = 256 if kind == "uint8" else 65536 if kind == "uint16" else 50
    stack = rng.integers(0, hi, (n, rows, cols)).astype(kind)
    if kind == "float64" and draw(st.booleans()):
        stack[rng.random(stack.shape) < 0.05] = np.nan
    at = (draw(st.integers(0, cols - 1)), draw(st.integers(0, rows - 1)))
    settings_ = {
        "search_px": draw(st.sampled_from([1, 3, 5, 11])),
        "box_px": draw(st.sampled_from([3, 5, 7])),
        "detrend": draw(st.booleans()),
        "ddof": draw(st.sampled_from([0, 1])),
    }
    if draw(st.booleans()):
        x0, y0 = draw(st.integers(0, cols - 2)), draw(st.integers(0, rows - 2))
        settings_["background"] = (
            x0,
            y0,
            draw(st.integers(x0 + 1, cols - 1)),
            draw(st.integers(y0 + 1, rows - 1)),
        )
    return stack, at, settings_


@settings(max_examples=150, deadline=None)
@given(case=_cases())
def test_stack_path_equals_per_frame_path_bit_for_bit(case):
    stack, at, cfg = case
    meter = PeakSnrMeter(**cfg)
    per_frame = [_bits(meter.measure(frame, at)) for frame in stack]
    assert [_bits(r) for r in measure_stack(stack, at, **cfg).to_list()] == per_frame


def test_equal_with_contamination_reference_running_stats_and_chunks():
    rng = np.random.default_rng(11)
    stack = rng.normal(2000.0, 6.0, (400, 48, 64))
    stack[:, 24, 30] += 90.0
    for start in (50, 150, 300):  # cloud edges drifting through the rim
        stack[start : start + 20, :, : 28 + (start % 3)] += rng.uniform(30, 80)
    stack[200:260] *= 2.5  # the sky gets noisier for good: the reference must re-learn it
    stack = np.rint(stack).astype(np.uint16)
    meter = PeakSnrMeter(window=50)
    expected = [_bits(meter.measure(f, (31, 23))) for f in stack]
    assert any("rim_contaminated" in e[3] for e in expected)
    for chunk in (400, 7):
        fresh = PeakSnrMeter(window=50)
        got = measure_stack(stack, (31, 23), meter=fresh, chunk_frames=chunk)
        assert [_bits(r) for r in got.to_list()] == expected
        assert fresh.running.mean == meter.running.mean
        assert fresh.running.std == meter.running.std
        assert fresh.reference_noise == meter.reference_noise
    # fed in two pieces, the stack path continues the meter's state
    split = PeakSnrMeter(window=50)
    first = measure_stack(stack[:123], (31, 23), meter=split).to_list()
    second = measure_stack(stack[123:], (31, 23), meter=split).to_list()
    assert [_bits(r) for r in first + second] == expected


def test_struct_of_arrays_view():
    stack = np.random.default_rng(1).integers(0, 100, (3, 12, 12)).astype(np.uint16)
    result = measure_stack(stack, (6, 6))
    assert len(result) == 3
    assert result.peak_x.shape == (3,) and result.flag_bits.dtype == np.uint8
    assert _bits(result[1]) == _bits(result.to_list()[1])
    assert result.flags(0) == result.to_list()[0].flags
