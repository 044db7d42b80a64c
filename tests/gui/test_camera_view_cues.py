"""The camera view's help for the click, offscreen, where a real window cannot reach: the
measured box's marker gone once zoomed in, the palettes' colour tables end to end, the exact DN
and the apparent temperature under the pointer, the loupe's pixels. The GPS ring beside the
drone, the box's marker, the palettes and the readout as painted in a real window:
tests/gui/test_real_window_camera_view.py."""

from __future__ import annotations

import numpy as np
import pytest

from snrmon.acquisition.engine.inputs import Measurement
from snrmon.acquisition.engine.status import CameraStatus, FrameAccounting
from snrmon.acquisition.measure.peak_snr import PeakSnr, PeakSnrConfig
from snrmon.acquisition.track.config import TrackState
from snrmon.drivers.device import DeviceStatus
from snrmon.gui.app import console_application
from snrmon.gui.camera_view import MIN_BOX_SCREEN_PX, PALETTES, CameraView

H, W = 720, 1280  # the MWIR's frame


@pytest.fixture
def view(qtbot):
    console_application(headless=True)
    v = CameraView("mwir", (H, W), PeakSnrConfig())
    qtbot.addWidget(v)
    return v


def status(x: int, y: int, gps_xy=None) -> CameraStatus:
    result = PeakSnr(x, y, 1400.0, 1000.0, 8.0, 50.0, frozenset())
    m = Measurement(
        "mwir", 1, 1, 0, result, TrackState.TRACKING, (x, y), 50.0, 2.0, 100, 126.0, "lrf"
    )
    return CameraStatus(
        "mwir",
        DeviceStatus("mwir"),
        FrameAccounting(),
        roi_xy=(x, y),
        gps_xy=gps_xy,
        track_state=TrackState.TRACKING,
        last=m,
    )


def test_the_box_is_marked_at_8_screen_px_where_the_frame_is_drawn_small(qtbot, view):
    view.resize(330, 230)  # a 1280-px frame about 252 px wide, as at 1366 x 768
    view.show()
    qtbot.waitExposed(view)
    view.reset_zoom()
    box_px = view.box_screen_px()
    assert box_px < MIN_BOX_SCREEN_PX  # the 7-px box is under 2 screen px here
    view.show_status(status(640, 360))
    assert view.box_marker.isVisible()
    assert view.box_marker.opts["pxMode"] and view.box_marker.opts["size"] >= MIN_BOX_SCREEN_PX
    xs, ys = view.box_marker.getData()
    assert (xs[0], ys[0]) == (640.5, 360.5)  # at the peak pixel's centre
    # zoomed in, the box itself is large enough: no marker over it
    view.view.setRange(xRange=(600, 680), yRange=(330, 390), padding=0.0)
    assert view.box_screen_px() >= MIN_BOX_SCREEN_PX
    view.show_status(status(640, 360))
    assert not view.box_marker.isVisible() and view.box_rect.isVisible()


@pytest.mark.parametrize("name", list(PALETTES))
def test_each_palette_colours_the_image(view, name):
    view.set_palette(name)
    lut = view.histogram.gradient.getLookupTable(256, alpha=False)
    low, high = lut[0][:3].tolist(), lut[-1][:3].tolist()
    if name in ("grey", "white-hot"):
        assert (low, high) == ([0, 0, 0], [255, 255, 255])
        assert np.all(lut[:, 0] == lut[:, 1]) and np.all(lut[:, 1] == lut[:, 2])  # grey
    elif name == "black-hot":
        assert (low, high) == ([255, 255, 255], [0, 0, 0])
    else:  # ironbow: black through purple, magenta and orange to near white
        assert low == [0, 0, 0] and min(high) > 200
        mid = lut[64]
        assert mid[2] > mid[1] and mid[0] < 100  # the blue-purple quarter
    assert view.palette == name
    with pytest.raises(ValueError, match="unknown palette"):
        view.set_palette("rainbow")


def test_the_value_under_the_pointer_is_the_shown_frame_s_dn(qtbot, view):
    from PySide6.QtCore import QPointF

    rng = np.random.default_rng(35)
    frame = rng.integers(900, 1100, (H, W), dtype=np.uint16)
    frame[360, 640] = 4321  # the drone's peak
    view.image.setImage(frame, autoLevels=False, levels=(900, 1100))
    scene = view.view.mapViewToScene(QPointF(640.5, 360.5))
    with qtbot.waitSignal(view.pointed, timeout=2000) as got:
        view._scene_moved(scene)  # what the scene's sigMouseMoved hands over
    assert got.args == ["mwir", 640, 360, 4321.0]
    assert view.value_at_scene(view.view.mapViewToScene(QPointF(12.2, 700.9))) == (
        12,
        700,
        float(frame[700, 12]),
    )
    assert view.value_at_scene(view.view.mapViewToScene(QPointF(-3.0, 5.0))) is None


def test_the_apparent_temperature_under_the_pointer_by_the_pixel_s_calibration():
    """With a calibration, the pointer's pixel reads as an apparent temperature: the raw DN
    through that pixel's own offset and responsivity, then the band's Planck inversion (a
    pixel's neighbour, with another offset, would read another temperature)."""
    from snrmon.acquisition.calibrate.calibration import Calibration, radiance_of
    from snrmon.acquisition.engine.camera_engine import CameraEngine

    shape = (40, 60)
    rng = np.random.default_rng(8)
    cal = Calibration(
        camera="mwir",
        band_um=(3.45, 5.25),
        t_int_s=0.001,
        temps_k=(283.0, 313.0),
        responsivity=rng.uniform(0.8, 1.2, shape).astype(np.float32) * 1e3,
        offset_dn=rng.uniform(900, 1100, shape).astype(np.float32),
        bad=np.zeros(shape, np.uint8),
        fit_rms_dn=np.zeros(shape, np.float32),
        temporal_noise_dn=np.ones(shape, np.float32),
    )
    engine = CameraEngine("mwir", shape)
    assert engine.apparent_temp_k(10, 20, 1500.0) is None  # no calibration: no temperature
    engine.set_calibration(cal)
    dn = float(cal.offset_dn[20, 10] + cal.responsivity[20, 10] * radiance_of(cal.band_um, 300.0))
    assert engine.apparent_temp_k(10, 20, dn) == pytest.approx(300.0, abs=1e-3)
    assert abs(engine.apparent_temp_k(11, 20, dn) - 300.0) > 0.01  # its neighbour's own map
    assert engine.apparent_temp_k(60, 20, dn) is None  # off the map


def test_the_loupe_magnifies_the_pixels_around_the_pointer(qtbot, view):
    from PySide6.QtCore import QPointF

    from snrmon.gui.camera_view import LOUPE_PX, LOUPE_ZOOM, loupe_rgb

    view.resize(900, 560)
    view.show()
    qtbot.waitExposed(view)
    frame = np.full((H, W), 1000, np.uint16)
    frame[360, 640] = 1100  # the drone: white at levels (1000, 1100)
    frame[360, 641] = 1050  # its neighbour: mid grey
    view.image.setImage(frame, autoLevels=False, levels=(1000, 1100))
    view._set_levels_quietly(1000, 1100)
    view.set_palette("grey")
    view._scene_moved(view.view.mapViewToScene(QPointF(640.5, 360.5)))
    loupe = view.loupe
    assert loupe.isVisible() and loupe.centre == (640, 360)
    side = LOUPE_PX * LOUPE_ZOOM
    assert (loupe.pixmap().width(), loupe.pixmap().height()) == (side, side)
    image = loupe.pixmap().toImage()
    mid = (LOUPE_PX // 2) * LOUPE_ZOOM + LOUPE_ZOOM // 2
    assert image.pixelColor(mid, mid).name() == "#ffffff"  # the drone, magnified
    right = image.pixelColor(mid + LOUPE_ZOOM, mid)
    assert right.red() == right.green() == right.blue() and 120 <= right.red() <= 135
    assert image.pixelColor(mid + 3 * LOUPE_ZOOM, mid).name() == "#000000"  # sky at the low level
    # the crop's colours as an independent reading: levels onto 0..255
    rgb = loupe_rgb(frame, 640, 360, (1000, 1100), None)
    assert rgb[LOUPE_PX // 2, LOUPE_PX // 2] & 0xFFFFFF == 0xFFFFFF
    edge = loupe_rgb(frame, 0, 0, (1000, 1100), None)  # beyond the frame's edge: black
    assert edge[0, 0] & 0xFFFFFF == 0 and edge.shape == (LOUPE_PX, LOUPE_PX)
