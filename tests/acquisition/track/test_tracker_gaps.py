"""Frames dropped before the tracker (camera or ring drops): told through ``update(frames=)`` /
``skip``, the motion model moves on over the gap and a drone off its prediction right after it is
looked for at once, found again within the confirmation frames instead of after ``lost_frames``
gate misses. Seeded synthetic frames; no gap, nothing changes."""

from __future__ import annotations

import numpy as np

from snrmon.acquisition.track.motion import MotionModel
from snrmon.acquisition.track.tracker import Tracker, TrackerConfig, TrackState

ROWS, COLS = 100, 120
SKY, NOISE = 1000.0, 10.0
GAP = 30  # frames dropped


def _frame(rng: np.random.Generator, x: float, y: float) -> np.ndarray:
    yy, xx = np.mgrid[0:ROWS, 0:COLS]
    a = SKY + rng.normal(0.0, NOISE, (ROWS, COLS))
    a += 150.0 * np.exp(-((xx - x) ** 2 + (yy - y) ** 2) / (2 * 0.8**2))
    return np.clip(np.rint(a), 0, 65535).astype(np.uint16)


def _run(path, n: int, told: bool, seed: int = 6):
    """Track the drone at ``path(i)`` over frames 0..n-1 with frames GAP..2 GAP-1 dropped;
    returns the steps of the frames the tracker saw, by frame index, and the tracker."""
    rng = np.random.default_rng(seed)
    tracker = Tracker(path(0))
    steps = {}
    for i in range(n):
        frame = _frame(rng, *path(i))  # the noise of dropped frames is drawn all the same
        if GAP <= i < 2 * GAP:
            continue
        frames = GAP + 1 if (told and i == 2 * GAP) else 1
        steps[i] = tracker.update(frame, frames=frames)
    return steps, tracker


def _hover_then_shift(i: int) -> tuple[float, float]:
    # Hovers at (60, 50); during the gap it moves 4 px right and hovers there: off the gate.
    return (60.0, 50.0) if i < GAP + 5 else (64.0, 50.0)


def _on(step, xy) -> bool:
    r = step.peak_snr
    return abs(r.peak_x - xy[0]) <= 1 and abs(r.peak_y - xy[1]) <= 1


def test_a_drone_that_moved_during_a_gap_is_back_within_the_confirmation_frames():
    n = 2 * GAP + 20
    steps, tracker = _run(_hover_then_shift, n, told=True)
    first = 2 * GAP
    assert steps[first - GAP - 1].state is TrackState.TRACKING
    # Off the gate right after the gap: searched for at once, and confirmed.
    assert (steps[first].reason, steps[first].misses) == ("confirming", 1)
    back = tracker.config.reacquire.frames - 1
    for i in range(first + back, n):
        assert steps[i].state is TrackState.TRACKING and steps[i].reason == "", i
        assert _on(steps[i], _hover_then_shift(i)), (i, steps[i].peak_snr)
    assert tracker.reacquisitions == 1


def test_untold_the_same_gap_costs_lost_frames_of_gate_misses():
    """What the engine did before it told the tracker: ~9 gate misses, then the search."""
    n = 2 * GAP + 20
    steps, _ = _run(_hover_then_shift, n, told=False)
    first = 2 * GAP
    assert [steps[first + k].reason for k in range(5)] == ["gate"] * 5
    assert not any(
        _on(steps[first + k], (64, 50)) and steps[first + k].reason == "" for k in range(5)
    )


def test_a_drone_flying_on_through_a_gap_is_followed_without_a_miss():
    def path(i):
        return 20.0 + 1.0 * i, 50.0  # 1 px a frame, right

    n = 2 * GAP + 10
    steps, tracker = _run(path, n, told=True)
    for i in range(2 * GAP, n):
        assert steps[i].reason == "" and steps[i].state is TrackState.TRACKING, i
        assert _on(steps[i], path(i)), (i, steps[i].peak_snr)
    assert tracker.reacquisitions == 0


def test_state_after_a_gap_restores_bit_for_bit():
    n = 2 * GAP + 12
    rng = np.random.default_rng(9)
    frames = [_frame(rng, *_hover_then_shift(i)) for i in range(n)]
    seen = [i for i in range(n) if not GAP <= i < 2 * GAP]
    a = Tracker(_hover_then_shift(0))
    ka = [a.update(frames[i], frames=GAP + 1 if i == 2 * GAP else 1) for i in seen[: GAP + 1]]
    assert ka[-1].state is TrackState.REACQUIRING  # confirming, the search widened
    state = a.snapshot()
    assert state["widen"] > 0
    b = Tracker((1, 1))
    b.restore(state)
    for i in seen[GAP + 1 :]:
        assert a.update(frames[i]) == b.update(frames[i]), i
    assert a.snapshot() == b.snapshot()


def test_skip_before_read_centre_and_no_gap_changes_nothing():
    rng = np.random.default_rng(3)
    frames = [_frame(rng, 30.0 + 0.5 * i, 40.0) for i in range(12)]
    a, b = Tracker((30, 40)), Tracker((30, 40))
    for f in frames:
        b.skip(0)
        assert a.update(f) == b.update(f, frames=1)
    assert a.snapshot() == b.snapshot()
    before = a.read_centre
    a.skip(4)  # the read square moves with the prediction before the frame is read
    assert a.read_centre[0] > before[0] + 1
    assert a.snapshot()["widen"] == 4 * int(TrackerConfig().reacquire.max_speed_px)


def test_motion_advance_keeps_the_velocity_and_the_image():
    m = MotionModel()
    m.reset(10.0, 10.0, 2.0, -1.0)
    m.advance(3)
    assert (m.x, m.y, m.vx, m.vy) == (16.0, 7.0, 2.0, -1.0)
    m.advance(50, bounds=(100, 20))
    assert (m.x, m.y) == (99.0, 0.0)
    m.advance(0)
    assert (m.x, m.y) == (99.0, 0.0)
