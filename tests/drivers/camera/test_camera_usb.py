"""USB camera identification and link-budget refusal, through a custom pyusb backend (pyusb's
documented ``usb.backend.IBackend`` extension point) that presents scripted descriptors."""

from __future__ import annotations

from types import SimpleNamespace

import pytest
import usb.backend
import usb.core

from snrmon.drivers.camera.format import CameraFormat
from snrmon.drivers.camera.usb import (
    LinkTooSlowError,
    UsbSpeed,
    link_utilisation,
    list_usb_cameras,
)


def fake_device(vid, pid, speed, interfaces, bus=1, address=4):
    """Descriptors for one device: ``interfaces`` is a list of (class, subclass)."""
    return SimpleNamespace(
        desc=SimpleNamespace(
            bLength=18,
            bDescriptorType=1,
            bcdUSB=0x0300,
            bDeviceClass=0xEF,
            bDeviceSubClass=2,
            bDeviceProtocol=1,
            bMaxPacketSize0=9,
            idVendor=vid,
            idProduct=pid,
            bcdDevice=0x0100,
            iManufacturer=0,
            iProduct=0,
            iSerialNumber=0,
            bNumConfigurations=1,
            address=address,
            bus=bus,
            port_number=1,
            port_numbers=(1,),
            speed=speed,
        ),
        interfaces=interfaces,
    )


class FakeBackend(usb.backend.IBackend):
    """Just enough of a pyusb backend to enumerate devices and read their descriptors."""

    def __init__(self, devices):
        self.devices = devices

    def enumerate_devices(self):
        return iter(self.devices)

    def get_device_descriptor(self, dev):
        return dev.desc

    def get_configuration_descriptor(self, dev, config):
        return SimpleNamespace(
            bLength=9,
            bDescriptorType=2,
            wTotalLength=9,
            bNumInterfaces=len(dev.interfaces),
            bConfigurationValue=1,
            iConfiguration=0,
            bmAttributes=0x80,
            bMaxPower=250,
            extra_descriptors=b"",
        )

    def get_interface_descriptor(self, dev, intf, alt, config):
        if alt > 0:
            raise IndexError("no alternate settings")
        cls, sub = dev.interfaces[intf]
        return SimpleNamespace(
            bLength=9,
            bDescriptorType=4,
            bInterfaceNumber=intf,
            bAlternateSetting=0,
            bNumEndpoints=0,
            bInterfaceClass=cls,
            bInterfaceSubClass=sub,
            bInterfaceProtocol=0,
            iInterface=0,
            extra_descriptors=b"",
        )


BOSON = fake_device(0x09CB, 0x4007, 3, [(0x0E, 1), (0x0E, 2), (0x02, 2), (0x0A, 0)], address=7)
U3V = fake_device(0x2676, 0xBA02, 4, [(0xEF, 5), (0xEF, 5), (0xEF, 5)], bus=2, address=3)
U3V_ON_USB2 = fake_device(0x2676, 0xBA02, 3, [(0xEF, 5)], bus=1, address=9)
KEYBOARD = fake_device(0x046D, 0xC31C, 1, [(0x03, 1)])
MWIR = CameraFormat(1280, 720, "Mono16", 60.0)


def test_cameras_are_identified_by_id_and_class_and_others_ignored():
    cams = list_usb_cameras(FakeBackend([KEYBOARD, BOSON, U3V]))
    assert [(c.usb_id, c.kind, c.speed) for c in cams] == [
        ("09cb:4007", "uvc", UsbSpeed.HIGH),
        ("2676:ba02", "u3v", UsbSpeed.SUPER),
    ]
    assert cams[0].description == "FLIR Boson (UVC + CDC control)"
    assert cams[0].address == 7 and cams[1].bus == 2
    assert cams[1].description == "USB3 Vision camera"
    assert cams[1].speed_name == "USB 3 SuperSpeed (5 Gbit/s)"


def test_mwir_format_is_refused_on_usb2_with_the_numbers():
    (cam,) = list_usb_cameras(FakeBackend([U3V_ON_USB2]))
    with pytest.raises(LinkTooSlowError) as err:
        link_utilisation(cam, MWIR)
    msg = str(err.value)
    assert "USB 2.0 high speed" in msg
    assert "110.6 MB/s" in msg and "53.2 MB/s" in msg
    assert "1280x720 Mono16 60 fps" in msg


def test_mwir_format_fits_usb3_and_boson_fits_usb2():
    (u3v,) = list_usb_cameras(FakeBackend([U3V]))
    assert link_utilisation(u3v, MWIR) == pytest.approx(1280 * 720 * 2 * 60 / 400e6)
    (boson,) = list_usb_cameras(FakeBackend([BOSON]))
    used = link_utilisation(boson, CameraFormat(640, 512, "Y16", 60.0))
    assert used == pytest.approx(640 * 512 * 2 * 60 / 53.248e6)


def test_unknown_rate_or_speed_cannot_be_judged():
    (boson,) = list_usb_cameras(FakeBackend([BOSON]))
    assert link_utilisation(boson, CameraFormat(640, 512, "Y16", None)) is None
    odd = fake_device(0x09CB, 0x4007, 0, [(0x0E, 1)])
    (cam,) = list_usb_cameras(FakeBackend([odd]))
    assert cam.speed is UsbSpeed.UNKNOWN and link_utilisation(cam, MWIR) is None


def test_no_backend_is_one_clear_error(monkeypatch):
    def no_backend(*a, **k):
        raise usb.core.NoBackendError("No backend available")

    monkeypatch.setattr(usb.core, "find", no_backend)
    with pytest.raises(OSError, match="no libusb backend"):
        list_usb_cameras()
