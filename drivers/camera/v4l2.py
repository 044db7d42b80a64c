"""UVC/V4L2 thermal cores (FLIR Boson/Tau class, PureThermal boards) through OpenCV.

Raw 16-bit frames need, in this order (OpenCV PRs #7293, #12454; flirpy ``camera/boson.py``):
``VideoCapture(dev, CAP_V4L2)``, ``set(CAP_PROP_FOURCC, 'Y16 ')``, then
``set(CAP_PROP_CONVERT_RGB, 0)``; otherwise OpenCV hands out 8-bit AGC'd BGR. The negotiated
size and ``CAP_PROP_FPS`` are read back and reported at start-up (the same Boson gives 60 Hz on a
laptop and 30 Hz on a Raspberry Pi, flirpy#84).

UVC carries no frame counter, so the counter here is the host's count of frames received:
drops inside the camera or the USB link cannot be seen (``dropped`` stays 0). The device
timestamp is the V4L2 buffer time (``CAP_PROP_POS_MSEC``) when the driver gives one.

``capture_factory`` is the OpenCV boundary: tests pass a fake capture object there because this
machine has no ``/dev/video*``.
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterable
from typing import Any

import numpy as np

from snrmon.drivers.camera.base import CameraDevice
from snrmon.drivers.camera.format import CameraFormat
from snrmon.drivers.camera.frame import Frame


def _opencv_capture(device: int | str, api: int) -> Any:
    import cv2

    return cv2.VideoCapture(device, api)


class V4l2Camera(CameraDevice):
    """A UVC camera read through OpenCV's V4L2 backend as raw Y16.

    Args:
        name: camera name in frames and status.
        device: ``/dev/videoN`` path or index N.
        width, height, fps: requested mode; ``None`` keeps the camera's default.
        capture_factory: ``factory(device, api) -> capture`` with OpenCV's ``VideoCapture``
            methods (``isOpened``, ``set``, ``get``, ``read``, ``release``); OpenCV's by default.
        **kw: passed to :class:`snrmon.drivers.device.Device`.
    """

    def __init__(
        self,
        name: str,
        device: int | str = 0,
        *,
        width: int | None = None,
        height: int | None = None,
        fps: float | None = None,
        capture_factory: Callable[[int | str, int], Any] | None = None,
        **kw: Any,
    ) -> None:
        super().__init__(name, **kw)
        for label, value in (("width", width), ("height", height), ("fps", fps)):
            if value is not None and value <= 0:
                raise ValueError(f"V4L2 camera {name}: {label} must be positive, got {value}")
        self.device = device
        self.request = (width, height, fps)
        self._factory = capture_factory or _opencv_capture
        self._cap: Any = None
        self._first: np.ndarray | None = None
        self._frames = 0

    def _connect(self) -> None:
        import cv2

        cap = self._factory(self.device, cv2.CAP_V4L2)
        if cap is None or not cap.isOpened():
            raise OSError(f"cannot open V4L2 device {self.device!r}")
        width, height, fps = self.request
        if width is not None:
            cap.set(cv2.CAP_PROP_FRAME_WIDTH, width)
        if height is not None:
            cap.set(cv2.CAP_PROP_FRAME_HEIGHT, height)
        if fps is not None:
            cap.set(cv2.CAP_PROP_FPS, fps)
        # The order matters: CONVERT_RGB is reset when the FOURCC changes.
        cap.set(cv2.CAP_PROP_FOURCC, cv2.VideoWriter_fourcc(*"Y16 "))
        cap.set(cv2.CAP_PROP_CONVERT_RGB, 0)
        fourcc = int(cap.get(cv2.CAP_PROP_FOURCC))
        fourcc_s = fourcc.to_bytes(4, "little").decode("ascii", "replace")
        if fourcc_s != "Y16 ":
            cap.release()
            raise OSError(f"V4L2 device {self.device!r} refused Y16 (negotiated {fourcc_s!r})")
        ok, first = cap.read()
        if ok and first is not None and (first.dtype != np.uint16 or first.ndim != 2):
            cap.release()
            # Some backends keep 8-bit colour despite CONVERT_RGB=0 (macOS, flirpy#7); a
            # radiometric console must not silently measure AGC'd video.
            raise OSError(
                f"V4L2 device {self.device!r} delivers {first.dtype} {first.shape}, "
                "not raw 16-bit Y16"
            )
        self._first = first if ok else None
        got_fps = float(cap.get(cv2.CAP_PROP_FPS))
        self._cap = cap
        self._frames = 0
        self._negotiated(
            CameraFormat(
                int(cap.get(cv2.CAP_PROP_FRAME_WIDTH)),
                int(cap.get(cv2.CAP_PROP_FRAME_HEIGHT)),
                "Y16",
                got_fps if got_fps > 0 else None,
            )
        )

    def _disconnect(self) -> None:
        if self._cap is not None:
            cap, self._cap = self._cap, None
            with contextlib.suppress(Exception):  # a vanished device may fail to release
                cap.release()

    def _read(self) -> Iterable[Frame]:
        import cv2

        if self._first is not None:
            ok, img, self._first = True, self._first, None
        else:
            ok, img = self._cap.read()
        if not ok or img is None:
            raise OSError(f"V4L2 device {self.device!r} returned no frame (unplugged?)")
        if img.dtype != np.uint16 or img.ndim != 2:
            raise OSError(
                f"V4L2 device {self.device!r} delivers {img.dtype} {img.shape}, not raw 16-bit"
            )
        counter = self._frames
        self._frames += 1
        self._account(counter)
        pos_ms = float(self._cap.get(cv2.CAP_PROP_POS_MSEC))
        return [
            Frame(
                pixels=img,
                camera=self.name,
                counter=counter,
                t_host_ns=time.monotonic_ns(),
                t_device_ns=round(pos_ms * 1e6) if pos_ms > 0 else None,
                meta={"format": self.format},
            )
        ]
