"""``snrmon devices``: what is plugged in -- serial ports (with USB ids), USB cameras (with link
speed), V4L2 video devices and Aravis (GigE Vision / USB3 Vision) cameras.

Each section says plainly when it found nothing or cannot look (no libusb backend, no gi).
"""

from __future__ import annotations

import argparse
import glob
import os
from pathlib import Path

from snrmon.drivers.camera.usb import list_usb_cameras
from snrmon.output import emit_json


def _section(devices: list[dict], available: bool = True, note: str = "") -> dict:
    if available and not devices and not note:
        note = "none found"
    return {"available": available, "devices": devices, "note": note}


def serial_ports() -> dict:
    """Serial ports from pyserial, with USB vendor:product ids where the port is USB."""
    from serial.tools import list_ports

    devices = []
    for p in sorted(list_ports.comports(), key=lambda p: p.device):
        usb_id = f"{p.vid:04x}:{p.pid:04x}" if p.vid is not None and p.pid is not None else None
        devices.append(
            {
                "device": p.device,
                "usb_id": usb_id,
                "description": p.description if p.description != "n/a" else "",
                "serial_number": p.serial_number,
                "manufacturer": p.manufacturer,
            }
        )
    return _section(devices)


def usb_cameras() -> dict:
    """Cameras on the USB bus (pyusb), with their link speed."""
    try:
        cams = list_usb_cameras()
    except OSError as exc:
        return _section([], available=False, note=str(exc))
    note = ""
    if not cams and os.name == "posix" and not os.path.isdir("/dev/bus/usb"):
        note = "none found (no /dev/bus/usb: this system sees no USB bus)"
    return _section(
        [
            {
                "usb_id": c.usb_id,
                "kind": c.kind,
                "description": c.description,
                "bus": c.bus,
                "address": c.address,
                "speed": c.speed_name,
                "link_MB_per_s": None if c.link_bytes_per_s is None else c.link_bytes_per_s / 1e6,
            }
            for c in cams
        ],
        note=note,
    )


def v4l2_devices(dev_dir: str = "/dev", sysfs: str = "/sys/class/video4linux") -> dict:
    """``/dev/video*`` nodes with the driver's name for each."""
    devices = []
    for path in sorted(glob.glob(os.path.join(dev_dir, "video*"))):
        name_file = Path(sysfs) / os.path.basename(path) / "name"
        try:
            name = name_file.read_text().strip()
        except OSError:
            name = ""
        devices.append({"device": path, "name": name})
    return _section(devices)


def aravis_cameras() -> dict:
    """GigE Vision / USB3 Vision cameras Aravis discovers (about 1 s)."""
    from snrmon.drivers.camera.aravis import AravisUnavailableError, list_aravis_cameras

    try:
        cams = list_aravis_cameras()
    except AravisUnavailableError as exc:
        return _section([], available=False, note=str(exc))
    return _section(
        [
            {
                "device_id": c.device_id,
                "address": c.address,
                "vendor": c.vendor,
                "model": c.model,
                "serial": c.serial,
                "protocol": c.protocol,
            }
            for c in cams
        ]
    )


SECTIONS = {
    "serial": ("Serial ports", serial_ports),
    "usb_cameras": ("USB cameras", usb_cameras),
    "v4l2": ("V4L2 video devices", v4l2_devices),
    "aravis": ("Aravis cameras (GigE Vision / USB3 Vision)", aravis_cameras),
}


def collect() -> dict[str, dict]:
    """Every section's findings, keyed as in ``--json`` output."""
    return {key: fn() for key, (_, fn) in SECTIONS.items()}


def _line(item: dict) -> str:
    return "  " + "  ".join(f"{k}={v}" for k, v in item.items() if v not in (None, ""))


def render(report: dict[str, dict]) -> str:
    """The human-readable listing: one heading per section, one line per device."""
    lines = []
    for key, (title, _) in SECTIONS.items():
        sec = report[key]
        lines.append(f"{title}:")
        lines.extend(_line(item) for item in sec["devices"])
        if sec["note"]:
            prefix = "  unavailable: " if not sec["available"] else "  "
            lines.append(prefix + sec["note"])
    return "\n".join(lines)


def register(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "devices", help="list serial ports, USB cameras, V4L2 devices and Aravis cameras"
    )
    p.add_argument("--json", action="store_true", help="print one JSON object")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    report = collect()
    if args.json:
        return emit_json(report, indent=2)
    print(render(report), flush=True)
    return 0
