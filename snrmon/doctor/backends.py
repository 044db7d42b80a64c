"""The libraries behind the camera drivers: libusb (USB identification and link speed), OpenCV's
V4L2 capture and the V4L2 device nodes, Aravis (GigE Vision / USB3 Vision)."""

from __future__ import annotations

import glob
import os
import re

from snrmon.doctor import FAIL, PASS, Check


def check_libusb(needed: bool) -> Check:
    """pyusb finds a libusb backend."""
    try:
        import usb.backend.libusb1 as libusb1

        backend = libusb1.get_backend()
    except Exception as exc:  # pyusb raises several kinds when the library is broken
        backend, why = None, str(exc)
    else:
        why = "no libusb-1.0 library found"
    if backend is not None:
        return Check("libusb", PASS, "pyusb has a libusb-1.0 backend", needed=needed)
    return Check(
        "libusb",
        FAIL,
        f"pyusb has no libusb backend ({why})",
        "sudo apt-get install libusb-1.0-0",
        needed=needed,
    )


def check_v4l2(devices: list[str], needed: bool) -> Check:
    """OpenCV was built with V4L2, and each configured V4L2 device node exists and may be
    opened (the ``video`` group)."""
    import cv2

    info = cv2.getBuildInformation()
    if not re.search(r"v4l/v4l2:\s+YES", info):
        return Check(
            "v4l2",
            FAIL,
            "this OpenCV has no V4L2 capture",
            "reinstall opencv-contrib-python-headless (make setup)",
            needed,
        )
    nodes = sorted(glob.glob("/dev/video*"))
    for dev in devices:
        path = dev if dev.startswith("/") else f"/dev/video{dev}"
        if not os.path.exists(path):
            return Check(
                "v4l2",
                FAIL,
                f"V4L2 device {path} does not exist (found: {', '.join(nodes) or 'none'})",
                "plug in the camera; `snrmon devices` "
                "lists V4L2 devices; set [cameras.NAME] address",
                needed,
            )
        if not os.access(path, os.R_OK | os.W_OK):
            return Check(
                "v4l2",
                FAIL,
                f"V4L2 device {path} is not readable and writable by this user",
                "sudo usermod -aG video $USER, then log out and back in",
                needed,
            )
    found = ", ".join(nodes) or "no /dev/video* now"
    return Check(
        "v4l2", PASS, f"OpenCV has V4L2 capture ({found})", needed=needed, data={"devices": nodes}
    )


def check_aravis(needed: bool) -> Check:
    """gi and the Aravis 0.8 typelib import."""
    from snrmon.drivers.camera.aravis import INSTALL_HINT, AravisUnavailableError, aravis_module

    try:
        arv = aravis_module()
    except AravisUnavailableError as exc:
        reason = str(exc).removeprefix(INSTALL_HINT).strip(" ()")
        return Check("aravis", FAIL, f"Aravis is not available ({reason})", INSTALL_HINT, needed)
    version = getattr(arv, "_version", "0.8")
    return Check("aravis", PASS, f"Aravis {version} (GigE Vision / USB3 Vision)", needed=needed)
