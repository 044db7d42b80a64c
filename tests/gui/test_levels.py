"""Display levels and the camera view's cheap drawing path: robust levels on a strided sample,
the levels dead band, the block mean that replaces pyqtgraph's downsampling, and what is painted.
"""

from __future__ import annotations

import numpy as np
import pyqtgraph as pg
import pytest
from PySide6.QtGui import QImage

from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
from snrmon.acquisition.streams.ring import RingFrame
from snrmon.gui.camera_view import CameraView, DisplayImageItem, block_mean
from snrmon.gui.levels import levels_moved, robust_levels


def _sky(h: int, w: int, seed: int = 1) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return np.clip(np.rint(rng.normal(1000.0, 8.0, (h, w))), 0, 65535).astype(np.uint16)


def _frame(pixels: np.ndarray, seq: int) -> RingFrame:
    return RingFrame(pixels=pixels, seq=seq, counter=seq, t_host_ns=0, t_device_ns=None)


class Camera:
    """A 96 x 160 camera as the display's feed sees it: its one frame, until it is replaced."""

    name, shape = "mwir", (96, 160)

    def __init__(self) -> None:
        self.frame: RingFrame | None = None

    def latest_frame(self, *, unless_seq=None, out=None):
        f = self.frame
        return None if f is None or f.seq == unless_seq else f


# ---------------------------------------------------------------------- levels
def test_robust_levels_ignore_a_hot_spot_and_match_the_full_frame_percentiles():
    sky = _sky(720, 1280)
    sky[300:304, 600:604] = 60000  # a glint: 16 of 921 600 pixels
    lo, hi = robust_levels(sky)
    full_lo, full_hi = np.percentile(sky, [0.5, 99.9])
    assert hi < 1100  # the glint did not stretch the window
    assert abs(lo - full_lo) <= 2.0 and abs(hi - full_hi) <= 3.0  # strided sample ~ whole frame


def test_robust_levels_flat_frame_and_bad_input():
    assert robust_levels(np.full((8, 8), 500, np.uint16)) == (500.0, 501.0)
    with pytest.raises(ValueError, match="percentiles"):
        robust_levels(_sky(8, 8), percentiles=(99.0, 1.0))
    with pytest.raises(ValueError, match="empty"):
        robust_levels(np.zeros((0, 4), np.uint16))


def test_levels_moved_only_beyond_the_tolerance_of_the_shown_window():
    shown = (1000.0, 1100.0)  # a 100 DN window, 3 % = 3 DN
    assert not levels_moved(shown, (1002.0, 1097.5))
    assert levels_moved(shown, (1004.0, 1100.0))
    assert levels_moved(shown, (1000.0, 1096.0))
    assert levels_moved((5.0, 5.0), (5.0, 5.0))  # a degenerate window is always replaced
    with pytest.raises(ValueError, match="tolerance"):
        levels_moved(shown, shown, tolerance=-0.1)


# ---------------------------------------------------------------------- block mean
def test_block_mean_is_the_rounded_mean_of_whole_blocks():
    rng = np.random.default_rng(4)
    img = rng.integers(0, 4000, (37, 50), dtype=np.uint16)  # neither axis divisible by 3 or 4
    out = block_mean(img, 4, 3)
    assert out.shape == (12, 12) and out.dtype == np.uint16
    want = img[:36, :48].reshape(12, 3, 12, 4).mean(axis=(1, 3))
    assert np.max(np.abs(out.astype(float) - want)) <= 0.5
    assert block_mean(img, 1, 1) is img


# ---------------------------------------------------------------------- drawing
def _gray(qimage: QImage) -> np.ndarray:
    q = qimage.convertToFormat(QImage.Format.Format_Grayscale8)
    buf = np.frombuffer(q.constBits(), np.uint8, q.sizeInBytes())
    return buf.reshape(q.height(), q.bytesPerLine())[:, : q.width()].copy()


LO, HI = 980.0, 1030.0


@pytest.mark.parametrize("factors", [(1, 1), (2, 2), (3, 2)])
def test_display_item_draws_what_pyqtgraph_draws(qtbot, monkeypatch, factors):
    """Same levels, same downsampling factors: the fast path's picture equals pyqtgraph's own,
    up to the block mean being rounded to a whole DN (0.5 DN = 2.6 grey steps in a 50 DN window)
    and one step of truncation; without downsampling, pixel for pixel."""
    sky = _sky(96, 160)
    sky[40, 70] = 1400  # a point target must survive the downsampling like pyqtgraph's
    images = []
    for cls in (pg.ImageItem, DisplayImageItem):
        item = cls(axisOrder="row-major", autoDownsample=True)
        monkeypatch.setattr(item, "_computeDownsampleFactors", lambda f=factors: f)
        item.setImage(sky, autoLevels=False, levels=(LO, HI))
        item.render()
        images.append(_gray(item.qimage))
    ref, fast = images
    assert fast.shape == ref.shape == (96 // factors[1], 160 // factors[0])
    grey_per_dn = 255.0 / (HI - LO)
    tolerance = 0 if factors == (1, 1) else int(np.ceil(0.5 * grey_per_dn)) + 1
    assert np.max(np.abs(fast.astype(int) - ref.astype(int))) <= tolerance
    # the point target is the brightest shown pixel in both pictures
    spot = (40 // factors[1], 70 // factors[0])
    assert fast[spot] == fast.max() and ref[spot] == ref.max()


def _rgb(qimage: QImage) -> np.ndarray:
    q = qimage.convertToFormat(QImage.Format.Format_RGB32)
    buf = np.frombuffer(q.constBits(), np.uint32, q.sizeInBytes() // 4)
    return (buf.reshape(q.height(), q.bytesPerLine() // 4)[:, : q.width()] & 0xFFFFFF).copy()


@pytest.mark.parametrize("dtype", [np.uint16, np.uint8])
def test_display_item_colours_as_pyqtgraph_colours(qtbot, monkeypatch, dtype):
    """With a colour map (the histogram's gradient gives one) and no downsampling, the 32-bit
    picture is pyqtgraph's own, pixel for pixel, for 16- and 8-bit frames."""
    sky = _sky(48, 64)
    levels = (LO, HI)
    if dtype == np.uint8:
        sky = (sky - 900).clip(0, 255).astype(np.uint8)
        levels = (60.0, 140.0)
    lut = np.random.default_rng(2).integers(0, 256, (256, 3), dtype=np.uint8)
    images = []
    for cls in (pg.ImageItem, DisplayImageItem):
        item = cls(axisOrder="row-major", autoDownsample=True)
        monkeypatch.setattr(item, "_computeDownsampleFactors", lambda: (1, 1))
        item.setImage(sky, autoLevels=False, levels=levels, lut=lut)
        item.render()
        images.append(_rgb(item.qimage))
    ref, fast = images
    assert fast.shape == ref.shape == sky.shape
    assert np.array_equal(fast, ref)


def test_view_draws_the_worker_s_image_and_levels_and_counts_painted_frames(qtbot):
    """Frames made ready by the display's worker: the view draws their levels and, once it has
    said how it draws, their image as it is (not made again on the GUI thread), and the picture
    is the one it would make itself."""
    from snrmon.gui.frame_feed import FrameFeed

    view = CameraView("mwir", (96, 160), PeakSnrConfig())
    qtbot.addWidget(view)
    view.resize(400, 300)
    view.show()
    qtbot.waitExposed(view)
    cam = Camera()
    feed = FrameFeed(cam)
    sky = _sky(96, 160)

    def show(pixels, seq):
        cam.frame = _frame(pixels, seq)
        assert feed.prepare()
        shown = feed.newest()
        drawn = view.show_frame(shown)
        qtbot.waitUntil(lambda: view.image.frames_painted == seq + 1, timeout=2000)
        feed.request = view.display_request()
        return drawn, shown

    assert show(sky, 0)[0]
    assert view.histogram.getLevels() == pytest.approx(robust_levels(sky))
    assert view.image.images_made_here == 1  # the first: the view had not said how it draws
    assert not view.show_frame(feed.newest())  # nothing new
    for seq in range(1, 4):
        drawn, shown = show(sky + seq, seq)
        assert drawn and shown.image is not None
        assert view.image.images_made_here == 1  # the worker's image, as it was made
    made = _rgb(view.image.qimage)
    view.image.prepared = None  # the same frame made on the GUI thread: the same picture
    view.image.render()
    assert np.array_equal(_rgb(view.image.qimage), made)
    assert view.image.frames_painted == view.frames_shown == 4


# ---------------------------------------------------------------------- histogram
@pytest.mark.parametrize("dtype", [np.uint16, np.uint8, np.float32])
def test_display_histogram_is_pyqtgraph_s_histogram_of_the_frame(qtbot, dtype):
    """The worker's histogram of a frame is the one pyqtgraph's ImageItem makes of it (its
    own code is the reference), for a noisy sky with a glint (bins wider than one DN)."""
    from snrmon.gui.levels import display_histogram

    sky = _sky(720, 1280).astype(np.float64)
    sky[300:304, 600:604] = 3000.0  # a glint: the span is ~2000 DN, 5 DN a bin
    if dtype == np.uint8:
        sky = np.clip(sky - 900.0, 0, 255)
    pixels = sky.astype(dtype)
    item = pg.ImageItem(axisOrder="row-major")
    item.setImage(pixels, autoLevels=False, levels=(0, 1))
    want_x, want_counts = item.getHistogram()
    got_x, got_counts = display_histogram(pixels)
    n = len(want_counts)
    assert np.allclose(got_x[:n], want_x) and np.array_equal(got_counts[:n], want_counts)
    assert not got_counts[n:].any()  # any bin beyond pyqtgraph's last one is empty
    assert got_counts.sum() == (720 // 4) * (1280 // 7 + 1)  # every 4th row, 7th column


def test_histogram_range_holds_still_for_a_noisy_sky_and_follows_a_new_scene():
    from snrmon.gui.levels import histogram_range

    shown = histogram_range(952.0, 1047.0)  # a sky of ~1000 +/- 8 DN with a few outliers
    assert shown[0] < 952.0 and shown[1] > 1047.0
    assert shown == (940.0, 1060.0)  # a span of 95: steps of 10 DN, one more on each side
    rng = np.random.default_rng(5)
    jitter = rng.integers(-3, 4, (50, 2))
    for lo, hi in zip(952.0 + jitter[:, 0], 1047.0 + jitter[:, 1], strict=True):
        assert histogram_range(float(lo), float(hi), shown) == shown  # frame to frame: still
    warm = histogram_range(1500.0, 1600.0, shown)  # the scene left the range
    assert warm[0] <= 1500.0 and warm[1] >= 1600.0 and warm != shown
    narrow = histogram_range(990.0, 1010.0, shown)  # a fifth of the range: zoom in
    assert narrow != shown and narrow[0] <= 990.0 and narrow[1] >= 1010.0


def test_the_view_plots_the_worker_s_histogram_without_moving_its_axis(qtbot, monkeypatch):
    """Frames with a histogram (the worker's, once a second) replot the levels control; the
    control's DN range stays put while the sky only jitters."""
    from snrmon.gui import frame_feed
    from snrmon.gui.frame_feed import FrameFeed

    clock = [100.0]
    monkeypatch.setattr(frame_feed.time, "monotonic", lambda: clock[0])
    view = CameraView("mwir", (96, 160), PeakSnrConfig())
    qtbot.addWidget(view)
    cam = Camera()
    feed = FrameFeed(cam)
    ranges, histograms = [], 0
    for seq in range(8):
        cam.frame = _frame(_sky(96, 160, seed=seq), seq)
        assert feed.prepare()
        shown = feed.newest()
        histograms += shown.histogram is not None
        view.show_frame(shown)
        if shown.histogram is not None:
            dn, counts = view.histogram.plot.getData()
            assert np.array_equal(dn, shown.histogram[0])
            assert np.array_equal(counts, shown.histogram[1])
            ranges.append(view.histogram.vb.viewRange()[1])
        clock[0] += 0.5  # two frames a second: a histogram every other frame
    assert histograms == 4
    assert all(r == pytest.approx(ranges[0]) for r in ranges)  # the axis did not move
    lo, hi = ranges[0]
    assert lo <= _sky(96, 160).min() and hi >= _sky(96, 160).max()
