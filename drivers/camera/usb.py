"""USB cameras found with pyusb: who they are (vendor/product id, class), how fast their link
is, and whether a configured format and rate can fit through it.

pyusb is used here only to enumerate and identify: the video itself goes through the kernel's UVC
driver (:mod:`snrmon.drivers.camera.v4l2`) or Aravis's USB3 Vision stack
(:mod:`snrmon.drivers.camera.aravis`). Reading descriptors needs no open device, so no permissions
beyond listing.

Link budgets are the largest bulk payload each USB speed can carry per second (USB 2.0 spec
5.8.4: 13 x 512-byte packets per 125 us microframe at high speed = 53.2 MB/s; 19 x 64 bytes per
1 ms frame at full speed). SuperSpeed figures are the usual ceilings after 8b/10b (5 Gbit/s) or
128b/132b (10 Gbit/s) line coding and protocol overhead, not spec maxima. A 1280x720 16-bit
60 fps stream needs 110.6 MB/s: it cannot run over USB 2.0.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from enum import IntEnum
from typing import Any

from snrmon.drivers.camera.format import CameraFormat


class UsbSpeed(IntEnum):
    """libusb's speed codes, as pyusb reports them in ``Device.speed``."""

    UNKNOWN = 0
    LOW = 1
    FULL = 2
    HIGH = 3
    SUPER = 4
    SUPER_PLUS = 5


SPEED_NAMES = {
    UsbSpeed.UNKNOWN: "unknown speed",
    UsbSpeed.LOW: "USB 1.x low speed (1.5 Mbit/s)",
    UsbSpeed.FULL: "USB 1.x full speed (12 Mbit/s)",
    UsbSpeed.HIGH: "USB 2.0 high speed (480 Mbit/s)",
    UsbSpeed.SUPER: "USB 3 SuperSpeed (5 Gbit/s)",
    UsbSpeed.SUPER_PLUS: "USB 3 SuperSpeed+ (10 Gbit/s)",
}

#: Largest payload in bytes per second each link speed carries (see module docstring).
LINK_PAYLOAD_BYTES_PER_S = {
    UsbSpeed.LOW: 800.0,
    UsbSpeed.FULL: 19 * 64 * 1000.0,
    UsbSpeed.HIGH: 13 * 512 * 8000.0,
    UsbSpeed.SUPER: 400e6,
    UsbSpeed.SUPER_PLUS: 900e6,
}

#: (vendor id, product id or None for any) -> what it is.
KNOWN_CAMERAS: dict[tuple[int, int | None], str] = {
    (0x09CB, 0x4007): "FLIR Boson (UVC + CDC control)",
    (0x09CB, None): "FLIR device",
    (0x1E4E, 0x0100): "GroupGets PureThermal (FLIR Lepton, UVC)",
    (0x1E10, None): "FLIR / Point Grey machine-vision camera",
}

USB_CLASS_VIDEO = 0x0E  # UVC
USB_CLASS_MISC = 0xEF
U3V_SUBCLASS = 0x05  # USB3 Vision: interface class 0xEF, subclass 0x05


class LinkTooSlowError(ValueError):
    """The configured format and rate need more than the camera's USB link carries."""


@dataclass(frozen=True, slots=True)
class UsbCamera:
    """One camera on the USB bus."""

    vendor_id: int
    product_id: int
    bus: int | None
    address: int | None
    speed: UsbSpeed
    kind: str  # "uvc", "u3v" or "vendor"
    description: str

    @property
    def speed_name(self) -> str:
        return SPEED_NAMES[self.speed]

    @property
    def link_bytes_per_s(self) -> float | None:
        """Largest payload rate of the link, ``None`` when the speed is unknown."""
        return LINK_PAYLOAD_BYTES_PER_S.get(self.speed)

    @property
    def usb_id(self) -> str:
        return f"{self.vendor_id:04x}:{self.product_id:04x}"


def link_utilisation(camera: UsbCamera, fmt: CameraFormat) -> float | None:
    """Fraction of the link's payload capacity that ``fmt`` needs; ``None`` if the link speed or
    the rate is unknown.

    Raises:
        LinkTooSlowError: the format needs more than the link carries.
    """
    capacity = camera.link_bytes_per_s
    need = fmt.bytes_per_s
    if capacity is None or need <= 0:
        return None
    if need > capacity:
        raise LinkTooSlowError(
            f"camera {camera.usb_id} ({camera.description}) on bus {camera.bus} is connected at "
            f"{camera.speed_name}, which carries at most {capacity / 1e6:.1f} MB/s; "
            f"{fmt} needs {need / 1e6:.1f} MB/s: use a USB 3 port and cable, or lower the "
            "rate or the region"
        )
    return need / capacity


def _interface_classes(dev: Any) -> set[tuple[int, int]]:
    classes = set()
    for cfg in dev:
        for intf in cfg:
            classes.add((intf.bInterfaceClass, intf.bInterfaceSubClass))
    return classes


def identify(dev: Any) -> UsbCamera | None:
    """A :class:`UsbCamera` for a pyusb device that is a camera, else ``None``."""
    vid, pid = dev.idVendor, dev.idProduct
    known = KNOWN_CAMERAS.get((vid, pid)) or KNOWN_CAMERAS.get((vid, None))
    try:
        classes = _interface_classes(dev)
    except Exception:  # unreadable configuration descriptor: judge by ids alone
        classes = set()
    if (USB_CLASS_MISC, U3V_SUBCLASS) in classes:
        kind, description = "u3v", known or "USB3 Vision camera"
    elif any(c == USB_CLASS_VIDEO for c, _ in classes):
        kind, description = "uvc", known or "UVC video device"
    elif known is not None:
        kind, description = "vendor", known
    else:
        return None
    try:
        speed = UsbSpeed(dev.speed or 0)
    except ValueError:
        speed = UsbSpeed.UNKNOWN
    return UsbCamera(vid, pid, dev.bus, dev.address, speed, kind, description)


def list_usb_cameras(backend: Any = None) -> list[UsbCamera]:
    """Every camera on the USB bus, found through ``backend`` (pyusb's libusb one by default).

    Raises:
        OSError: no libusb backend is available (saying what to install).
    """
    import usb.core

    try:
        devices: Iterable[Any] = list(usb.core.find(find_all=True, backend=backend))
    except usb.core.NoBackendError as exc:
        raise OSError(
            "no libusb backend for pyusb: apt-get install libusb-1.0-0 "
            "(or pip install libusb-package)"
        ) from exc
    cameras = [identify(d) for d in devices]
    return [c for c in cameras if c is not None]
