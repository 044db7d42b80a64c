"""GigE Vision and USB3 Vision cameras through Aravis 0.8 (GObject introspection, optional).

``gi`` and the ``Aravis-0.8`` typelib are imported only when an Aravis camera is made or listed;
without them :func:`aravis_module` raises :class:`AravisUnavailableError` saying what to install.

The camera is set to the requested region, pixel format (``Mono16``) and rate, and what it
actually agreed to is read back and reported. Each buffer's ``frame_id`` (the GVSP block id, 16
bits in GigE Vision 1.x: it runs 1..65535 then 1 again) is the frame counter; gaps are drops. The
buffer timestamp is the device timestamp. Incomplete buffers (missing packets) are not delivered,
so they appear as drops too. A camera that stops sending, loses control (heartbeat), or vanishes
is reopened by the device contract's reconnect loop.
"""

from __future__ import annotations

import contextlib
import threading
import time
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any

import numpy as np

from snrmon.drivers.camera.base import CameraDevice
from snrmon.drivers.camera.format import CameraFormat
from snrmon.drivers.camera.frame import Frame

INSTALL_HINT = (
    "Aravis cameras need PyGObject and the Aravis 0.8 typelib: "
    "apt-get install gir1.2-aravis-0.8 libgirepository1.0-dev libcairo2-dev pkg-config, then "
    "pip install 'PyGObject<3.51' (or use a venv with --system-site-packages and python3-gi)"
)
_DTYPES = {"Mono16": np.dtype("<u2")}  # Frame is uint16: raw IR only


class AravisUnavailableError(OSError):
    """gi or the Aravis typelib is missing; the message says what to install."""


def aravis_module() -> Any:
    """The ``gi.repository.Aravis`` module, imported on first use."""
    try:
        import gi

        gi.require_version("Aravis", "0.8")
        from gi.repository import Aravis
    except (ImportError, ValueError) as exc:
        raise AravisUnavailableError(f"{INSTALL_HINT} ({exc})") from exc
    return Aravis


@dataclass(frozen=True, slots=True)
class AravisDeviceInfo:
    """One camera Aravis can see."""

    device_id: str
    address: str
    vendor: str
    model: str
    serial: str
    protocol: str


def list_aravis_cameras() -> list[AravisDeviceInfo]:
    """Every GigE Vision / USB3 Vision camera Aravis discovers (about 1 s of discovery)."""
    Aravis = aravis_module()
    Aravis.update_device_list()
    return [
        AravisDeviceInfo(
            Aravis.get_device_id(i) or "",
            Aravis.get_device_address(i) or "",
            Aravis.get_device_vendor(i) or "",
            Aravis.get_device_model(i) or "",
            Aravis.get_device_serial_nbr(i) or "",
            Aravis.get_device_protocol(i) or "",
        )
        for i in range(Aravis.get_n_devices())
    ]


class AravisCamera(CameraDevice):
    """A GenICam camera streamed through Aravis.

    Args:
        name: camera name in frames and status.
        device_id: Aravis device id, IP address or ``None`` for the first camera found.
        width, height: region from (0, 0).
        pixel_format: ``"Mono16"`` (the only format a Frame can carry).
        fps: requested acquisition frame rate.
        exposure_us: exposure time to set, ``None`` to leave it.
        n_buffers: buffers queued to the stream.
        packet_size: GigE Vision packet size in bytes (jumbo frames), ``None`` to leave it.
        **kw: passed to :class:`snrmon.drivers.device.Device`.
    """

    def __init__(
        self,
        name: str,
        device_id: str | None = None,
        *,
        width: int = 1280,
        height: int = 720,
        pixel_format: str = "Mono16",
        fps: float = 60.0,
        exposure_us: float | None = None,
        n_buffers: int = 16,
        packet_size: int | None = None,
        **kw: Any,
    ) -> None:
        super().__init__(name, counter_modulus=1 << 16, zero_skipped=True, **kw)
        if pixel_format not in _DTYPES:
            raise ValueError(f"Aravis camera {name}: unsupported pixel format {pixel_format!r}")
        if width <= 0 or height <= 0 or fps <= 0 or n_buffers < 2:
            raise ValueError(
                f"Aravis camera {name}: bad request {width}x{height} at {fps} fps, "
                f"{n_buffers} buffers"
            )
        self._Aravis = aravis_module()
        self.device_id = device_id
        self.request = (width, height, pixel_format, fps)
        self.exposure_us = exposure_us
        self.n_buffers = n_buffers
        self.packet_size = packet_size
        self._cam: Any = None
        self._arv_stream: Any = None
        self._control_lost = threading.Event()
        self.incomplete_buffers = 0

    def _connect(self) -> None:
        from gi.repository import GLib

        Aravis = self._Aravis
        width, height, pixel_format, fps = self.request
        try:
            cam = Aravis.Camera.new(self.device_id)
            cam.set_region(0, 0, width, height)
            cam.set_pixel_format_from_string(pixel_format)
            cam.set_frame_rate(fps)
            if self.exposure_us is not None:
                cam.set_exposure_time(self.exposure_us)
            if self.packet_size is not None and cam.is_gv_device():
                cam.gv_set_packet_size(self.packet_size)
            region = cam.get_region()
            got_format = cam.get_pixel_format_as_string()
            got_fps = float(cam.get_frame_rate())
            self._control_lost.clear()
            cam.get_device().connect("control-lost", lambda *_: self._control_lost.set())
            stream = cam.create_stream(None, None)
            payload = cam.get_payload()
            for _ in range(self.n_buffers):
                stream.push_buffer(Aravis.Buffer.new_allocate(payload))
            cam.start_acquisition()
        except GLib.Error as exc:
            raise OSError(f"Aravis camera {self.device_id or '(first)'}: {exc.message}") from exc
        if got_format not in _DTYPES:
            cam.stop_acquisition()
            raise OSError(f"Aravis camera {self.name} negotiated {got_format}, not {pixel_format}")
        self._cam, self._arv_stream = cam, stream
        self._dtype = _DTYPES[got_format]
        self._negotiated(CameraFormat(region.width, region.height, got_format, got_fps))

    def _disconnect(self) -> None:
        cam, self._cam, self._arv_stream = self._cam, None, None
        if cam is not None:
            with contextlib.suppress(Exception):  # the camera may be gone already
                cam.stop_acquisition()

    def _read(self) -> Iterable[Frame]:
        if self._control_lost.is_set():
            raise OSError(f"Aravis camera {self.name}: control lost")
        buf = self._arv_stream.timeout_pop_buffer(100_000)  # microseconds
        if buf is None:
            return []
        try:
            if buf.get_status() != self._Aravis.BufferStatus.SUCCESS:
                # Not delivered: the next good frame_id shows the gap as a drop.
                self.incomplete_buffers += 1
                self._set(last_error=f"incomplete buffer: {buf.get_status().value_nick}")
                return []
            h, w = buf.get_image_height(), buf.get_image_width()
            # get_data() returns a fresh bytes copy (PyGObject), so the array can be kept.
            pixels = np.frombuffer(buf.get_data(), self._dtype)[: h * w].reshape(h, w)
            counter = int(buf.get_frame_id())
            t_device = int(buf.get_timestamp()) or None
        finally:
            self._arv_stream.push_buffer(buf)
        self._account(counter)
        return [
            Frame(
                pixels=pixels,
                camera=self.name,
                counter=counter,
                t_host_ns=time.monotonic_ns(),
                t_device_ns=t_device,
                meta={"format": self.format},
            )
        ]

    def stream_statistics(self) -> dict[str, int]:
        """Aravis's own counts for the current stream (resent and missing packets)."""
        if self._arv_stream is None:
            return {}
        resent, missing = self._arv_stream.get_statistics()[:2]
        return {"resent_packets": int(resent), "missing_packets": int(missing)}
