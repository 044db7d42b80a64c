"""One contract, run against every camera driver with its simulator (the python-microscope
mixin pattern, as tests/drivers/test_device_contract.py does for the serial devices): frames
arrive as ``Frame`` (2-D uint16 of the negotiated format), counters and host timestamps rise,
status counts them, close is clean."""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from snrmon.drivers.camera.frame import Frame
from snrmon.drivers.camera.shm import ShmCamera
from snrmon.drivers.camera.v4l2 import V4l2Camera
from snrmon.drivers.device import DeviceState
from snrmon.sim.devices.shm_camera import RandomPattern, ShmProducer
from tests.drivers.camera.test_camera_aravis import fake_gv  # noqa: F401 (the fixture)
from tests.drivers.camera.test_camera_v4l2 import FakeCapture


def collect(device, n: int, timeout_s: float = 10.0) -> list[Frame]:
    got: list[Frame] = []
    done = threading.Event()

    def on(frame: Frame) -> None:
        got.append(frame)
        if len(got) >= n:
            done.set()

    unsubscribe = device.subscribe(on)
    assert done.wait(timeout_s), f"{len(got)} of {n} frames in {timeout_s} s: {device.status()}"
    unsubscribe()
    return got[:n]


class CameraContract:
    """Subclasses provide ``make(request)`` -> (source or None, camera) and ``shape``."""

    shape: tuple[int, int]

    def make(self, request):
        raise NotImplementedError

    @pytest.fixture
    def camera(self, request):
        source, cam = self.make(request)
        yield cam
        cam.close()
        if source is not None:
            source.stop()

    def test_frames_typed_counted_and_timestamped(self, camera) -> None:
        camera.open()
        before = time.monotonic_ns()
        frames = collect(camera, 5)
        after = time.monotonic_ns()
        for f in frames:
            assert isinstance(f, Frame) and f.camera == camera.name
            assert f.pixels.dtype == np.uint16 and f.pixels.shape == self.shape
        counters = [f.counter for f in frames]
        stamps = [f.t_host_ns for f in frames]
        assert counters == sorted(counters) and len(set(counters)) == len(counters)
        assert stamps == sorted(stamps) and stamps[-1] <= after
        assert stamps[-1] >= before
        st = camera.status()
        assert st.state is DeviceState.STREAMING and st.readings >= 5
        assert camera.format is not None
        assert (camera.format.height, camera.format.width) == self.shape

    def test_close_stops_frames_and_reports_disconnected(self, camera) -> None:
        camera.open()
        collect(camera, 1)
        camera.close()
        n = camera.status().readings
        assert camera.status().state is DeviceState.DISCONNECTED
        more = threading.Event()
        camera.subscribe(lambda f: more.set())
        assert not more.wait(0.3) and camera.status().readings == n


class TestShmCameraContract(CameraContract):
    shape = (48, 64)

    def make(self, request):
        name = f"snrmon-contract-{time.monotonic_ns() % 10**9}"
        producer = ShmProducer(name, 64, 48, RandomPattern(64, 48, seed=2), fps=200.0)
        producer.start()
        return producer, ShmCamera("shm", name)


class TestV4l2CameraContract(CameraContract):
    shape = (512, 640)

    def make(self, request):
        # No /dev/video here: the fake capture object stands at the OpenCV boundary.
        return None, V4l2Camera("v4l2", 0, fps=60.0, capture_factory=FakeCapture)


@pytest.mark.integration
class TestAravisCameraContract(CameraContract):
    shape = (720, 1280)

    def make(self, request):
        request.getfixturevalue("fake_gv")  # skips with the reason where Aravis is absent
        from snrmon.drivers.camera.aravis import AravisCamera

        return None, AravisCamera("gige", "127.0.0.1", exposure_us=10000, packet_size=8972)
