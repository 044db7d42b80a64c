"""V4L2/UVC camera through OpenCV, tested at the OpenCV boundary with a fake VideoCapture (this
machine has no /dev/video*; the fake models OpenCV's rule that 16-bit frames come only when
CONVERT_RGB is set to 0 after the Y16 FOURCC)."""

from __future__ import annotations

import queue

import cv2
import numpy as np
import pytest

from snrmon.drivers.camera.format import CameraFormat
from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.camera.v4l2 import V4l2Camera
from snrmon.drivers.device import DeviceState

Y16 = cv2.VideoWriter_fourcc(*"Y16 ")


class FakeCapture:
    """Behaves like cv2.VideoCapture on a Boson: Y16 supported, 60 fps max."""

    def __init__(self, device, api, *, accept_y16=True, fail_after=None, max_fps=60.0):
        self.device, self.api = device, api
        self.calls: list[tuple[int, float]] = []
        self.props = {
            cv2.CAP_PROP_FRAME_WIDTH: 640.0,
            cv2.CAP_PROP_FRAME_HEIGHT: 512.0,
            cv2.CAP_PROP_FPS: 30.0,
            cv2.CAP_PROP_FOURCC: float(cv2.VideoWriter_fourcc(*"YUYV")),
            cv2.CAP_PROP_CONVERT_RGB: 1.0,
        }
        self.accept_y16, self.fail_after, self.max_fps = accept_y16, fail_after, max_fps
        self.reads = 0
        self.released = False
        self.rng = np.random.default_rng(5)

    def isOpened(self):  # noqa: N802 (OpenCV's name)
        return True

    def set(self, prop, value):
        self.calls.append((prop, value))
        if prop == cv2.CAP_PROP_FOURCC:
            if value == Y16 and not self.accept_y16:
                return False
            self.props[prop] = float(value)
            self.props[cv2.CAP_PROP_CONVERT_RGB] = 1.0  # OpenCV resets it on a format change
            return True
        if prop == cv2.CAP_PROP_FPS:
            value = min(value, self.max_fps)
        self.props[prop] = float(value)
        return True

    def get(self, prop):
        if prop == cv2.CAP_PROP_POS_MSEC:
            return 1000.0 + self.reads * 1000.0 / self.props[cv2.CAP_PROP_FPS]
        return self.props.get(prop, 0.0)

    def read(self):
        if self.fail_after is not None and self.reads >= self.fail_after:
            return False, None
        self.reads += 1
        h, w = int(self.props[cv2.CAP_PROP_FRAME_HEIGHT]), int(self.props[cv2.CAP_PROP_FRAME_WIDTH])
        raw16 = (
            int(self.props[cv2.CAP_PROP_FOURCC]) == Y16 and not self.props[cv2.CAP_PROP_CONVERT_RGB]
        )
        if raw16:
            return True, self.rng.integers(0, 1 << 14, (h, w), dtype=np.uint16)
        return True, np.zeros((h, w, 3), np.uint8)

    def release(self):
        self.released = True


def collect(cam: V4l2Camera, n: int) -> list[Frame]:
    q: queue.Queue[Frame] = queue.Queue()
    cam.subscribe(q.put)
    with cam:
        return [q.get(timeout=5) for _ in range(n)]


def test_y16_then_convert_rgb_in_that_order_gives_raw_16_bit_frames():
    caps: list[FakeCapture] = []
    cam = V4l2Camera(
        "lwir",
        "/dev/video0",
        fps=60,
        capture_factory=lambda d, a: caps.append(FakeCapture(d, a)) or caps[-1],
    )
    frames = collect(cam, 5)
    cap = caps[0]
    assert cap.api == cv2.CAP_V4L2 and cap.device == "/dev/video0"
    props = [p for p, _ in cap.calls]
    assert props.index(cv2.CAP_PROP_FOURCC) < props.index(cv2.CAP_PROP_CONVERT_RGB)
    assert cam.format == CameraFormat(640, 512, "Y16", 60.0)
    assert [f.counter for f in frames] == [0, 1, 2, 3, 4]
    assert all(f.pixels.dtype == np.uint16 and f.pixels.shape == (512, 640) for f in frames)
    assert frames[1].t_device_ns - frames[0].t_device_ns == pytest.approx(1e9 / 60, abs=1)
    assert cap.released


def test_negotiated_rate_is_what_the_camera_reports_not_what_was_asked():
    cam = V4l2Camera(
        "lwir", 0, fps=60, capture_factory=lambda d, a: FakeCapture(d, a, max_fps=30.0)
    )
    collect(cam, 1)
    assert cam.format is not None and cam.format.fps == 30.0


def test_camera_without_y16_is_refused_with_the_fourcc_named():
    cam = V4l2Camera(
        "lwir",
        0,
        max_attempts=1,
        capture_factory=lambda d, a: FakeCapture(d, a, accept_y16=False),
    )
    failed: queue.Queue = queue.Queue()
    cam.subscribe_status(lambda st: st.state is DeviceState.FAILED and failed.put(st))
    cam.open()
    st = failed.get(timeout=5)
    cam.close()
    assert "refused Y16" in st.last_error and "YUYV" in st.last_error


def test_8_bit_frames_despite_y16_are_refused():
    class Rgb(FakeCapture):
        def read(self):
            return True, np.zeros((512, 640, 3), np.uint8)

    cam = V4l2Camera("lwir", 0, max_attempts=1, capture_factory=lambda d, a: Rgb(d, a))
    failed: queue.Queue = queue.Queue()
    cam.subscribe_status(lambda st: st.state is DeviceState.FAILED and failed.put(st))
    cam.open()
    st = failed.get(timeout=5)
    cam.close()
    assert "not raw 16-bit" in st.last_error


def test_unplugged_camera_is_reopened_and_counted():
    made: list[FakeCapture] = []

    def factory(d, a):
        made.append(FakeCapture(d, a, fail_after=3 if not made else None))
        return made[-1]

    cam = V4l2Camera("lwir", 0, backoff_s=(0.01, 0.05), capture_factory=factory)
    frames = collect(cam, 6)
    assert len(made) == 2 and made[0].released
    assert cam.status().reconnects == 1
    assert [f.counter for f in frames] == [0, 1, 2, 0, 1, 2]  # host count restarts per open


def test_bad_request_names_the_value():
    with pytest.raises(ValueError, match="fps must be positive, got -5"):
        V4l2Camera("lwir", 0, fps=-5)
