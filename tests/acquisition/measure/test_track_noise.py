"""The noise panel's numbers (paper section 6), computed on the processing side.

Unit level: which pixels, how often, and the sqrt(2) convention, against estimate_noise on the
same pixels. Session level: a shared-memory camera renders 6 DN of white noise over a 15 DN
fixed pattern; the reported temporal noise must be the rendered noise and the spatial noise the
pattern's std over the pixels around the track.
"""

from __future__ import annotations

import math
import time

import numpy as np
import pytest

from snrmon.acquisition.config import session_config_from_dict
from snrmon.acquisition.measure.noise import estimate_noise
from snrmon.acquisition.measure.noise3d import noise_3d
from snrmon.acquisition.measure.track_noise import TrackNoise, ring_pixels
from snrmon.acquisition.runtime.session import Session
from snrmon.sim.devices.shm_camera import ShmProducer
from tests.helpers import NOISE_DN, H, SpotOnNoise, W, wait_until

FPN_DN = 15.0
FRAME_NS = 16_666_667  # 60 fps


def test_ring_pixels_leave_out_the_box_and_clip_at_the_border():
    rows, cols = ring_pixels((H, W), (64, 41), 41, 7)
    assert rows.size == 41 * 41 - 49
    assert not np.any((np.abs(rows - 41) <= 3) & (np.abs(cols - 64) <= 3))
    rows, cols = ring_pixels((H, W), (2, 2), 41, 7)  # corner: 23 x 23 square minus 6 x 6 box
    assert rows.size == 23 * 23 - 36 and rows.min() == 0 and cols.min() == 0


def test_estimates_at_most_four_per_second_from_consecutive_frames():
    render = SpotOnNoise(3, fpn_dn=FPN_DN)
    noise = TrackNoise((H, W), box_px=7)
    assert math.isnan(noise.figures()[0])
    frames = [render(k) for k in range(60)]  # one second at 60 fps
    for k, f in enumerate(frames):
        noise.update(f, k * FRAME_NS, (64, 41))
        if k == 1:  # armed on frame 0, measured on frame 1: exactly estimate_noise(1, 0)
            sel = ring_pixels((H, W), (64, 41), 41, 7)
            want = estimate_noise(frames[1][sel].reshape(1, -1), frames[0][sel].reshape(1, -1))
            assert noise.latest == want
            # the sqrt(2) convention: temporal = std(difference) / sqrt(2)
            diff = frames[1][sel].astype(float) - frames[0][sel]
            assert noise.latest.temporal_dn == pytest.approx(np.std(diff, ddof=1) / math.sqrt(2))
    assert noise.estimates == 4  # frames 0, 15, 30, 45 armed: 250 ms apart


def test_clear_sky_rectangle_needs_no_track_and_no_rectangle_no_track_means_unknown():
    render = SpotOnNoise(4, fpn_dn=FPN_DN)
    rect = (4, 60, 43, 89)
    noise = TrackNoise((H, W), background=rect, detrend=True)
    noise.update(render(0), 0, None)
    noise.update(render(1), FRAME_NS, None)
    want = estimate_noise(render(1), render(0), region=rect, detrend=True)
    assert noise.latest.total_dn == pytest.approx(want.total_dn, rel=1e-12)
    assert noise.latest.temporal_dn == pytest.approx(want.temporal_dn, rel=1e-12)
    assert noise.latest.detrended

    untracked = TrackNoise((H, W))
    untracked.update(render(0), 0, None)
    untracked.update(render(1), FRAME_NS, None)
    assert all(math.isnan(v) for v in untracked.figures())


def test_3d_noise_of_the_band_clear_of_the_track_over_blocks_of_100_frames():
    render = SpotOnNoise(5, fpn_dn=FPN_DN)
    frames = np.stack([render(k) for k in range(231)])
    noise = TrackNoise((H, W), box_px=7)
    cube = noise.cube
    for k in range(99):
        noise.update(frames[k], k * FRAME_NS, (64, 41))
    assert cube.latest is None  # not a whole block yet
    # the target's box (44, 21)-(84, 61); the largest band clear of it: the 34 rows below
    assert cube.region == (0, 62, W - 1, H - 1)
    noise.update(frames[99], 99 * FRAME_NS, (64, 41))
    got = cube.latest
    assert got.region == (0, 62, W - 1, H - 1)
    want = noise_3d(frames[:100, 62:, :])
    assert got.noise.sigma_corrected == want.sigma_corrected and got.noise.ci95 == want.ci95
    # the pattern this camera has there (its pixel-to-pixel part) and the rendered noise
    fpn = render.fpn[62:, :]
    vh = fpn - fpn.mean(axis=0) - fpn.mean(axis=1, keepdims=True) + fpn.mean()
    lo, hi = got.noise.ci95["vh"]
    assert lo <= math.sqrt(np.sum(vh**2) / ((H - 63) * (W - 1))) <= hi
    assert got.noise.sigma_corrected["tvh"] == pytest.approx(math.hypot(NOISE_DN, 12**-0.5), 0.02)
    # the drone flies into the band: a new band, the block starts again, the last figure stays
    for k in range(100, 130):
        noise.update(frames[k], k * FRAME_NS, (64, 80))
    assert cube.region == (0, 0, W - 1, 59) and cube.latest is got
    noise.update(frames[130], 130 * FRAME_NS, None)  # track lost: no region
    assert cube.region is None and cube.latest is got
    for k in range(131, 230):
        noise.update(frames[k], k * FRAME_NS, (64, 80))
    assert cube.latest is got  # 99 frames of the new band
    noise.update(frames[230], 230 * FRAME_NS, (64, 80))
    assert cube.latest.region == (0, 0, W - 1, 59) and cube.latest.noise.frames == 100


def test_3d_noise_on_the_clear_sky_rectangle_needs_no_track():
    render = SpotOnNoise(6)
    rect = (4, 60, 43, 89)
    noise = TrackNoise((H, W), background=rect)
    frames = [render(k) for k in range(100)]
    for k, f in enumerate(frames):
        noise.update(f, k * FRAME_NS, None)
    want = noise_3d(np.stack(frames)[:, 60:90, 4:44])
    assert noise.cube.latest.region == rect
    assert noise.cube.latest.noise.sigma == want.sigma


def test_bad_region_size_is_refused():
    with pytest.raises(ValueError, match="noise region"):
        TrackNoise((H, W), box_px=7, region_px=7)


def test_session_reports_rendered_temporal_noise_and_the_fixed_pattern():
    name = f"snrmon-noise-{time.monotonic_ns() % 10**9}"
    render = SpotOnNoise(21, fpn_dn=FPN_DN)
    producer = ShmProducer(name, W, H, render, fps=60.0, slots=16)
    producer.start()
    config = session_config_from_dict(
        {"cameras": {"cam": {"source": "shm", "address": name, "width_px": W, "height_px": H}}}
    )
    session = Session(config)
    try:
        session.start()
        cam = session.status().cameras["cam"]
        assert math.isnan(cam.figures.noise_total_dn)  # no track, no rectangle: unknown
        session.set_roi("cam", 65, 40)
        pipe = session.pipelines["cam"]
        wait_until(lambda: pipe.engine.noise.estimates >= 3, 10.0, "three noise estimates")
        cam = session.status().cameras["cam"]
    finally:
        session.stop()
        producer.stop()
    # The spot's pixel is (64, 41) or (64, 40) depending on the frame's noise; the region
    # follows the peak, and the pattern's std over either region differs by < 1 %.
    peak = (cam.last.result.peak_x, cam.last.result.peak_y)
    assert abs(peak[0] - 64) <= 1 and abs(peak[1] - 41) <= 1
    sel = ring_pixels((H, W), peak, 41, 7)
    n = sel[0].size  # 1632 pixels
    # Rendered temporal noise: 6 DN Gaussian, rounded to integers (+1/12 DN^2).
    rendered = math.sqrt(NOISE_DN**2 + 1 / 12)
    # The std of a sample std of n pixels is ~ sigma / sqrt(2 (n - 1)) (1.8 % here): 10 % is
    # over 5 sigma, and a temporal noise without the sqrt(2) would be 41 % high.
    assert cam.figures.noise_temporal_dn == pytest.approx(rendered, rel=0.10)
    # The pattern the camera really has over those pixels (this realisation, not 15 DN).
    pattern = float(np.std(render.fpn[sel], ddof=1))
    assert cam.figures.noise_spatial_dn == pytest.approx(pattern, rel=0.08)
    assert cam.figures.noise_total_dn == pytest.approx(math.hypot(pattern, rendered), rel=0.06)
    assert n == 41 * 41 - 49
