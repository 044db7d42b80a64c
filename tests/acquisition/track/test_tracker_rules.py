"""The tracker's new rules on seeded synthetic stacks: the click picks the compact
object, birds near a lost track are not accepted, a drone merged with a saturated treeline is
reported occluded and found again, and bad input gets one clear message."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.measure.peak_snr import RUNNING_EXCLUDED
from snrmon.acquisition.track.config import SearchConfig
from snrmon.acquisition.track.tracker import Tracker, TrackerConfig, TrackState, track_stack
from snrmon.benchmarks.real_clips import inseparable

ROWS, COLS = 100, 120
SKY, NOISE = 1000.0, 10.0


def _sky(n: int, seed: int) -> np.ndarray:
    return SKY + np.random.default_rng(seed).normal(0.0, NOISE, (n, ROWS, COLS))


def _spot(frame, x, y, amplitude, sigma=0.8):
    yy, xx = np.mgrid[0:ROWS, 0:COLS]
    frame += amplitude * np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * sigma**2))


def _u16(a):
    return np.clip(np.rint(a), 0, 65535).astype(np.uint16)


def _gone_then_birds(bird_amp: float, bird_speed: float, seed: int):
    """A drone (peak ~15 sigma) hovers at (60, 50) for 20 frames and vanishes; from frame 35 a
    bird crosses the old position, 2 rows below it, left to right."""
    n = 70
    stack = _sky(n, seed)
    bird = {}
    for i in range(n):
        if i < 20:
            _spot(stack[i], 60, 50, 150.0)
        x = 30 + bird_speed * (i - 35)
        if i >= 35 and x < COLS - 5:
            bird[i] = x
            _spot(stack[i], x, 52, bird_amp, sigma=0.7)
    return _u16(stack), bird


@pytest.mark.parametrize(
    ("bird_amp", "speed", "why"),
    [(750.0, 2.0, "five times brighter"), (150.0, 7.0, "as bright, but 7 px per frame")],
)
def test_a_bird_crossing_near_a_lost_track_is_not_accepted(bird_amp, speed, why):
    stack, bird = _gone_then_birds(bird_amp, speed, seed=11)
    tracker = Tracker((60, 50))
    steps = [tracker.update(f) for f in stack]
    assert steps[29].state is TrackState.LOST  # 10 misses from frame 20
    for i in bird:
        assert steps[i].state in (TrackState.LOST, TrackState.REACQUIRING), (i, why)
        assert "lost" in steps[i].peak_snr.flags
    assert tracker.reacquisitions == 0, why


def test_the_drone_coming_back_after_a_bird_is_reacquired_within_a_second():
    stack, _bird = _gone_then_birds(750.0, 2.0, seed=12)
    for i in range(55, len(stack)):  # back at its place after the bird
        frame = stack[i].astype(float)
        _spot(frame, 60, 50, 150.0)
        stack[i] = _u16(frame)
    steps = track_stack(stack, (60, 50))
    back = next(i for i in range(55, len(stack)) if steps[i].state is TrackState.TRACKING)
    assert back - 55 <= 30  # 1 s at 30 fps (here: reacquire.frames)
    assert all((s.peak_snr.peak_x, s.peak_snr.peak_y) == (60, 50) for s in steps[back:])


def _treeline_dip(n=60, seed=13):
    """A saturated 9x5 px drone descending 0.5 px/frame onto a saturated treeline (rows >= 70),
    merging with it around frame 30, then climbing away again from frame 40."""
    stack = _sky(n, seed)
    stack[:, 70:, :] = 4095.0
    boxes = []
    for i in range(n):
        y = min(55 + 0.5 * i, 70.0) if i <= 40 else 70.0 - 0.5 * (i - 40)
        x0, y0 = 55, round(y) - 2
        stack[i, y0 : y0 + 5, x0 : x0 + 9] = 4095.0
        boxes.append(np.array([x0, y0, x0 + 8, y0 + 4], float))
    return np.clip(stack, 0, 4095).astype(np.uint16), boxes


def test_a_drone_merged_with_saturated_clutter_is_occluded_not_followed_onto_it():
    stack, boxes = _treeline_dip()
    merged = [
        inseparable(f.astype(float) / 4095 * 255, b) for f, b in zip(stack, boxes, strict=False)
    ]
    assert any(merged) and not merged[0] and not merged[-1]
    steps = track_stack(stack, (59, 56))
    for s, box, joined in zip(steps, boxes, merged, strict=True):
        if joined:  # never claims the drone while it cannot be told from the treeline
            assert s.state in (TrackState.OCCLUDED, TrackState.LOST, TrackState.REACQUIRING)
            assert "lost" in s.peak_snr.flags
        elif s.state is TrackState.TRACKING:
            assert box[0] - 2 <= s.peak_snr.peak_x <= box[2] + 2
            assert box[1] - 2 <= s.peak_snr.peak_y <= box[3] + 2
    # Out of the treeline again: tracked before the end.
    assert steps[-1].state is TrackState.TRACKING


def test_a_click_off_the_drone_towards_a_treeline_selects_the_drone():
    """A faint drone 4 rows above a brighter treeline: a click 3 px towards the treeline still
    selects the drone (the treeline is no compact object)."""
    stack = _sky(10, 14)
    stack[:, 58:, :] += 600.0  # a treeline 8 rows below the drone, 4x brighter than it
    for f in stack:
        _spot(f, 60, 50, 150.0)
    steps = track_stack(_u16(stack), (60, 53))
    assert all(s.state is TrackState.TRACKING for s in steps)
    assert all((s.peak_snr.peak_x, s.peak_snr.peak_y) == (60, 50) for s in steps[1:])


def test_bad_input_is_one_clear_message_and_the_state_says_why():
    stack = _sky(3, 15)
    with pytest.raises(ValueError, match=r"click at x=130, y=5 is off the 120x100 image"):
        Tracker((130, 5)).update(_u16(stack[0]))
    # A click in a saturated region with nothing compact in it: lost, and why.
    sat = stack.copy()
    sat[:, 40:, :] = 65535.0
    step = Tracker((60, 70)).update(_u16(sat[0]))
    assert step.state is TrackState.LOST and step.reason == "no_object"
    assert "lost" in step.peak_snr.flags
    # A frame of another size than the track's.
    t = Tracker((60, 50))
    t.update(_u16(stack[0]))
    with pytest.raises(ValueError, match=r"frame of 60x100 px, but the track runs on 120x100"):
        t.update(_u16(stack[1][:, :60]))
    with pytest.raises(ValueError, match="2-D"):
        t.update(_u16(stack))
    with pytest.raises(ValueError, match=r"tracker search\.max_px must be an integer >= 1, got 0"):
        SearchConfig(max_px=0)


def test_the_console_status_says_why_the_track_is_not_tracking():
    from snrmon.acquisition.engine.frame_measurer import FrameMeasurer
    from snrmon.acquisition.streams.ring import RingFrame
    from snrmon.acquisition.track.config import TrackState

    sat = _sky(1, 16)[0]
    sat[40:, :] = 65535.0
    measurer = FrameMeasurer()
    measurer.set_roi(60, 70)
    pixels = _u16(sat)
    m = measurer.measure(pixels, RingFrame(pixels, 0, 0, 0, None, "cam"))
    assert (m.track_state, m.track_reason) == (TrackState.LOST, "no_object")


def test_reads_stay_within_reach_of_the_read_centre_through_a_gps_cue():
    """The engine corrects only the square of reach_px around read_centre: a track lost far
    from where the cue then puts the drone must read around the cue, nowhere else."""
    from snrmon.acquisition.measure.blob import BlobConfig
    from snrmon.acquisition.track.tracker import reach_px

    rows, cols = 300, 400
    rng = np.random.default_rng(17)
    yy, xx = np.mgrid[0:rows, 0:cols]
    frames = []
    for i in range(70):
        f = SKY + rng.normal(0.0, NOISE, (rows, cols))
        x, y = (60, 50) if i < 20 else (330, 240)  # gone at 20 frames, back far away at 30
        if i < 20 or i >= 30:
            f += 150.0 * np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * 0.8**2))
        frames.append(_u16(f))
    config = TrackerConfig(search=SearchConfig(max_px=24), blob=BlobConfig(max_half_px=16))
    full, cropped = Tracker((60, 50), config), Tracker((60, 50), config)
    half = reach_px(config, full.measurement)
    assert 2 * half + 1 < cols / 2
    steps = []
    for i, f in enumerate(frames):
        if i == 40:
            for t in (full, cropped):
                t.cue(331.4, 238.8)
        x, y = cropped.read_centre
        masked = np.full_like(f, 65535)
        y0, x0 = max(y - half, 0), max(x - half, 0)
        masked[y0 : y + half + 1, x0 : x + half + 1] = f[y0 : y + half + 1, x0 : x + half + 1]
        a, b = full.update(f), cropped.update(masked)
        assert (a == b and a.peak_snr.snr == b.peak_snr.snr) or np.isnan(a.peak_snr.snr), i
        steps.append(a)
    assert steps[39].state is TrackState.LOST  # too far for the capped search
    assert steps[40].state is TrackState.GPS_CUED
    assert (steps[-1].peak_snr.peak_x, steps[-1].peak_snr.peak_y) == (330, 240)


def test_the_track_keeps_the_measurers_one_noise_reference_and_running_statistics():
    """Eq. (4) alone and the track keep their memory by one rule in one place: while tracking,
    the measurer's noise reference (the one its state records) is the one the track judges
    contamination against, and its running statistics hold every valid frame's SNR."""
    from snrmon.acquisition.engine.frame_measurer import FrameMeasurer
    from snrmon.acquisition.streams.ring import RingFrame

    stack = _sky(30, 11)
    for frame in stack:
        _spot(frame, 60, 50, 150.0)
    frames = _u16(stack)
    measurer = FrameMeasurer()
    measurer.set_roi(60, 50)
    valid = []
    for i, pixels in enumerate(frames):
        m = measurer.measure(pixels, RingFrame(pixels, i, i, i, None, "cam"))
        if not m.result.flags & RUNNING_EXCLUDED:
            valid.append(m.result.snr)
    meter, tracker = measurer.meter, measurer.tracker
    assert meter.reference_noise is not None
    assert meter.reference_noise == tracker.reference_noise
    assert meter.running.count == len(valid) > 20
    assert meter.running.mean == pytest.approx(np.mean(valid), rel=1e-12)
    # the state a recording keeps holds the reference the track used
    state = measurer.snapshot()
    assert state["meter"]["reference"] == state["tracker"]["reference"]
    assert len(state["meter"]["reference"]["recent"]) > 0
