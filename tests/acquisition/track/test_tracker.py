"""The tracker on synthetic seeded stacks: intruders, fade-out and GPS cue, identity with Eq. 4."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.measure.peak_snr import (
    FLAG_RIM_CONTAMINATED,
    PeakSnrConfig,
    PeakSnrMeter,
    measure_peak_snr,
)
from snrmon.acquisition.track.config import AppearanceConfig
from snrmon.acquisition.track.tracker import Tracker, TrackerConfig, TrackState, track_stack

ROWS, COLS = 100, 120
SKY_DN, NOISE_DN = 1000.0, 10.0


def _spot(frame: np.ndarray, x: float, y: float, amplitude: float, sigma: float = 0.8) -> None:
    yy, xx = np.mgrid[0:ROWS, 0:COLS]
    frame += amplitude * np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * sigma**2))


def _sky(n: int, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return SKY_DN + rng.normal(0.0, NOISE_DN, (n, ROWS, COLS))


def _to_u16(stack: np.ndarray) -> np.ndarray:
    return np.clip(np.rint(stack), 0, 65535).astype(np.uint16)


def _bird_stack(dy: int, seed: int, n: int = 40):
    """A hovering drone (peak SNR ~15) at (60, 50); a bird 5x brighter flies across the search
    window ``dy`` rows below it (a compact spot, 3 DN at 2 px from its centre) at 2 px/frame
    (x = 44 at frame 10 ... 76 at frame 26)."""
    stack = _sky(n, seed)
    bird_x = {}
    for i in range(n):
        _spot(stack[i], 60, 50, 150.0)
        if 10 <= i <= 26:
            bird_x[i] = 44 + 2 * (i - 10)
            _spot(stack[i], bird_x[i], 50 + dy, 750.0, sigma=0.6)
    return _to_u16(stack), bird_x


def test_brighter_bird_crossing_the_window_does_not_capture_the_track():
    stack, bird_x = _bird_stack(dy=5, seed=1)
    steps = track_stack(stack, (60, 50))
    # Without the tracker's gate, the plain Eq. 4 window takes the bird while it is inside:
    captured = [i for i in bird_x if measure_peak_snr(stack[i], (60, 50)).peak_y == 55]
    assert len(captured) >= 4
    for i, s in enumerate(steps):
        assert s.state is TrackState.TRACKING
        assert (s.peak_snr.peak_x, s.peak_snr.peak_y) == (60, 50), i
        assert "lost" not in s.peak_snr.flags
        assert s.window_x == 60 and s.window_y == 50
    # Those frames were measured inside the gate (a 7x7 search) and are fine measurements.
    assert {i for i, s in enumerate(steps) if s.search_px == 7} == set(captured)
    assert min(s.peak_snr.snr for s in steps) > 8.0


def test_without_gate_and_brightness_test_the_bird_captures_the_track():
    # The same stack with the protections switched off: the track leaves the drone. This is
    # what the previous test guards against.
    stack, _ = _bird_stack(dy=5, seed=1)
    steps = track_stack(
        stack,
        (60, 50),
        TrackerConfig(gate_px=20, appearance=AppearanceConfig(brightness_factor=1e9)),
    )
    assert any(s.window_y != 50 or s.window_x != 60 for s in steps)


def test_bird_through_the_gate_is_refused_not_followed():
    # dy = 3: the bird enters the gate and the drone's rim; those frames are refused (flagged
    # lost or rim-contaminated) but the track does not move and is not lost.
    stack, bird_x = _bird_stack(dy=3, seed=2)
    steps = track_stack(stack, (60, 50))
    refused = [i for i, s in enumerate(steps) if s.reason]
    assert refused and set(refused) <= set(bird_x)
    for s in steps:
        assert s.state is TrackState.TRACKING
        assert (s.window_x, s.window_y) == (60, 50)
        if s.reason == "":
            assert (s.peak_snr.peak_x, s.peak_snr.peak_y) == (60, 50)
        else:
            assert s.reason in {"bright", "contaminated"}
            assert s.peak_snr.flags & {"lost", "rim_contaminated"}
    # Back on the drone after the bird.
    assert all(s.reason == "" for s in steps[30:])


def _fade_stack(n: int = 110, back_at: int = 60, back_xy=(68, 46), seed: int = 3) -> np.ndarray:
    """The drone at (60, 50) for 30 frames, gone until ``back_at``, then back at ``back_xy``."""
    stack = _sky(n, seed=seed)
    for i in range(n):
        if i < 30:
            _spot(stack[i], 60, 50, 150.0)
        elif i >= back_at:
            _spot(stack[i], *back_xy, 150.0)
    return _to_u16(stack)


def test_fade_out_is_lost_then_reacquired_without_a_cue():
    stack = _fade_stack()
    tracker = Tracker((60, 50))
    steps = [tracker.update(f) for f in stack]

    assert all(s.state is TrackState.TRACKING for s in steps[:30])
    first_lost = next(i for i, s in enumerate(steps) if s.state is TrackState.LOST)
    # lost_frames = 10 misses: frames 30..39. Noise peaks in the gate are far dimmer than the
    # track's median prominence, so none restarts the count.
    assert first_lost == 39
    assert all(s.reason == "faint" for s in steps[30:40])
    # While lost the measurement holds at the last good peak and every frame is flagged.
    for s in steps[first_lost:60]:
        assert s.state is TrackState.LOST and "lost" in s.peak_snr.flags
        assert (s.window_x, s.window_y) == (60, 50)
    # Back 8 px right and 4 up (outside the gate): found by the growing search, confirmed over
    # reacquire.frames (3) frames, flagged lost while confirming, then tracked again.
    assert [s.state for s in steps[60:62]] == [TrackState.REACQUIRING] * 2
    assert all("lost" in s.peak_snr.flags for s in steps[60:62])
    assert all((s.peak_snr.peak_x, s.peak_snr.peak_y) == (68, 46) for s in steps[60:])
    for s in steps[62:]:
        assert s.state is TrackState.TRACKING and not s.peak_snr.flags & {"lost", "gps_cued"}
    assert tracker.reacquisitions == 1


def test_a_lost_drone_is_reacquired_at_the_gps_cue_at_once():
    stack = _fade_stack()
    cues = [None] * len(stack)
    cues[60] = (66.2, 48.7)  # projected GPS position, ~3 px off, as the drone comes back
    steps = track_stack(stack, (60, 50), cues=cues)
    assert all(s.state is TrackState.LOST for s in steps[39:60])
    cued = steps[60]
    assert cued.state is TrackState.GPS_CUED and cued.reason == ""
    assert (cued.peak_snr.peak_x, cued.peak_snr.peak_y) == (68, 46)
    assert "gps_cued" in cued.peak_snr.flags and "lost" not in cued.peak_snr.flags
    assert (cued.window_x, cued.window_y) == (66, 49)  # searched in the cue square
    # Confirmed after cue.confirm_frames (5) accepted frames, the cued one included, then tracking.
    assert [s.state for s in steps[61:64]] == [TrackState.GPS_CUED] * 3
    assert all("gps_cued" in s.peak_snr.flags for s in steps[61:64])
    for s in steps[64:]:
        assert s.state is TrackState.TRACKING and not s.peak_snr.flags & {"lost", "gps_cued"}
        assert (s.peak_snr.peak_x, s.peak_snr.peak_y) == (68, 46)


def test_a_cue_on_empty_sky_does_not_reacquire():
    stack = _to_u16(_sky(40, seed=4))
    tracker = Tracker((60, 50), lost_frames=3)
    for frame in stack[:10]:
        tracker.update(frame)
    assert tracker.track_state is TrackState.LOST
    tracker.cue(30.0, 30.0)
    steps = [tracker.update(f) for f in stack[10:]]
    assert all(s.state is TrackState.LOST and s.reason == "faint" for s in steps)
    with pytest.raises(ValueError, match="GPS cue"):
        tracker.cue(float("nan"), 3.0)


def _stationary(seed: int, n: int = 60) -> np.ndarray:
    stack = _sky(n, seed)
    for i in range(n):
        _spot(stack[i], 40, 30, 150.0)
    return _to_u16(stack)


@pytest.mark.parametrize("reference", [None, 12.0])
def test_stationary_window_is_bit_identical_to_measure_peak_snr(reference):
    stack = _stationary(seed=5)
    steps = track_stack(stack, (40, 30), reference_noise=reference)
    for frame, s in zip(stack, steps, strict=True):
        assert (s.window_x, s.window_y) == (40, 30)
        assert s.peak_snr == measure_peak_snr(frame, (40, 30), reference_noise=reference)


def test_stationary_window_with_recent_noise_reference_matches_the_meter():
    stack = _stationary(seed=6)
    meter = PeakSnrMeter()
    steps = track_stack(stack, (40, 30))
    for frame, s in zip(stack, steps, strict=True):
        assert s.peak_snr == meter.measure(frame, (40, 30))


def test_tracker_measures_with_the_whole_measurement_config():
    # One source of the Eq. (4) settings: a tightened contamination test flags frames in
    # tracking exactly as it does in the fixed-point meter (the factors used to be dropped).
    stack = _stationary(seed=6)
    strict = PeakSnrConfig(contamination_std_factor=1.02, contamination_gradient_factor=1.5)
    meter = PeakSnrMeter(strict)
    steps = track_stack(stack, (40, 30), measurement=strict)
    flagged = [FLAG_RIM_CONTAMINATED in s.peak_snr.flags for s in steps]
    assert any(flagged) and not all(flagged)
    default_flags = [
        FLAG_RIM_CONTAMINATED in s.peak_snr.flags for s in track_stack(stack, (40, 30))
    ]
    assert flagged != default_flags
    for frame, s in zip(stack, steps, strict=True):
        assert s.peak_snr == meter.measure(frame, (40, 30))


def test_click_near_the_drone_moves_the_window_onto_it():
    stack = _stationary(seed=7, n=5)
    steps = track_stack(stack, (43, 28))
    assert (steps[0].window_x, steps[0].window_y) == (43, 28)
    assert all((s.peak_snr.peak_x, s.peak_snr.peak_y) == (40, 30) for s in steps)
    assert all((s.window_x, s.window_y) == (40, 30) for s in steps[1:])


def test_bad_settings_are_clear_errors():
    with pytest.raises(ValueError, match="gate_px"):
        TrackerConfig(gate_px=0)
    with pytest.raises(ValueError, match="reference_noise"):
        Tracker((1, 1), reference_noise="median")
