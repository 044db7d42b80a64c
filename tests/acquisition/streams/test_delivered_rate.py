"""The frames a camera delivered per second, on explicit clocks (no waiting): the rate of the
frames noted, overruns counted as delivered, a restart as one frame, a stall falling to 0."""

from __future__ import annotations

import pytest

from snrmon.acquisition.streams.delivered_rate import DeliveredRate

MS = 1_000_000  # ns


def test_the_rate_is_the_frames_over_their_span():
    rate = DeliveredRate(window_s=2.0)
    for k in range(61):  # 60 frames a second for a second
        rate.frame(k, t_ns=round(k * 1000 * MS / 60))
    assert rate.per_s(now_ns=1000 * MS + 5 * MS) == pytest.approx(60.0)


def test_frames_skipped_by_the_processing_are_delivered_all_the_same():
    rate = DeliveredRate()
    # every third frame taken (the ring overran twice between two): 30 delivered a second
    for k in range(0, 31, 3):
        rate.frame(k, t_ns=round(k * 1000 * MS / 30))
    assert rate.per_s(now_ns=1000 * MS) == pytest.approx(30.0)


def test_frames_dropped_by_the_camera_are_not():
    rate = DeliveredRate()
    # a 60-frame/s camera that loses every other frame on its link: the ring numbers only the
    # frames it received, 30 a second
    for k in range(31):
        rate.frame(k, t_ns=round(k * 1000 * MS / 30))
    assert rate.per_s(now_ns=1000 * MS) == pytest.approx(30.0)


def test_a_stalled_camera_falls_to_zero():
    rate = DeliveredRate(window_s=2.0)
    for k in range(61):
        rate.frame(k, t_ns=round(k * 1000 * MS / 60))
    stalled_1s = rate.per_s(now_ns=2000 * MS)  # the last frame a second ago
    assert stalled_1s == pytest.approx(60 / 2.0, rel=0.02)  # 60 frames over the 2 s since
    assert rate.per_s(now_ns=3500 * MS) == 0.0  # none in the window


def test_a_restart_counts_one_frame_and_nothing_before_two():
    rate = DeliveredRate()
    assert rate.per_s(now_ns=0) == 0.0
    rate.frame(100, t_ns=0)
    assert rate.per_s(now_ns=10 * MS) == 0.0
    rate.frame(5, t_ns=100 * MS)  # a replay's seek back: one frame, not -95
    assert rate.per_s(now_ns=100 * MS) == pytest.approx(10.0)


def test_the_window_must_be_positive():
    with pytest.raises(ValueError, match="window"):
        DeliveredRate(window_s=0.0)
