"""``snrmon devices``: every section is present, says plainly when empty or unavailable, and
lists what it finds (serial ports with USB ids, USB cameras with link speed, V4L2 nodes)."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from snrmon.cli import main
from snrmon.commands import devices
from snrmon.drivers.camera import usb as usb_cam
from tests.drivers.camera.test_camera_usb import BOSON, U3V_ON_USB2, FakeBackend
from tests.helpers import strict_json


@pytest.fixture
def no_aravis(monkeypatch):
    """Aravis discovery takes about a second; its listing is tested with the fake camera."""
    monkeypatch.setitem(
        devices.SECTIONS,
        "aravis",
        ("Aravis cameras", lambda: devices._section([], False, "gi not installed (test)")),
    )


def test_json_has_every_section_in_one_shape(capsys, no_aravis):
    assert main(["devices", "--json"]) == 0
    report = strict_json(capsys.readouterr().out)
    assert set(report) == {"serial", "usb_cameras", "v4l2", "aravis"}
    for sec in report.values():
        assert isinstance(sec["available"], bool) and isinstance(sec["devices"], list)
        assert sec["devices"] or sec["note"]  # never silently empty


def test_listing_shows_usb_ids_link_speed_and_video_nodes(monkeypatch, tmp_path, capsys, no_aravis):
    ports = [
        SimpleNamespace(
            device="/dev/ttyUSB0",
            vid=0x067B,
            pid=0x2303,
            description="USB-Serial Controller",
            serial_number=None,
            manufacturer="Prolific",
        ),
        SimpleNamespace(
            device="/dev/ttyS0",
            vid=None,
            pid=None,
            description="n/a",
            serial_number=None,
            manufacturer=None,
        ),
    ]
    monkeypatch.setattr("serial.tools.list_ports.comports", lambda: ports)
    backend = FakeBackend([BOSON, U3V_ON_USB2])
    monkeypatch.setattr(devices, "list_usb_cameras", lambda: usb_cam.list_usb_cameras(backend))
    (tmp_path / "video0").touch()
    (tmp_path / "sys" / "video0").mkdir(parents=True)
    (tmp_path / "sys" / "video0" / "name").write_text("Boson: FLIR Video\n")
    monkeypatch.setitem(
        devices.SECTIONS,
        "v4l2",
        ("V4L2 video devices", lambda: devices.v4l2_devices(str(tmp_path), str(tmp_path / "sys"))),
    )
    assert main(["devices"]) == 0
    out = capsys.readouterr().out
    assert "device=/dev/ttyUSB0  usb_id=067b:2303" in out
    assert "device=/dev/ttyS0" in out and "n/a" not in out
    assert "usb_id=09cb:4007  kind=uvc  description=FLIR Boson" in out
    assert "speed=USB 2.0 high speed (480 Mbit/s)  link_MB_per_s=53.248" in out
    assert f"device={tmp_path}/video0  name=Boson: FLIR Video" in out
    assert "unavailable: gi not installed (test)" in out


def test_missing_libusb_and_nothing_found_are_said_plainly(monkeypatch, tmp_path):
    def no_backend():
        raise OSError("no libusb backend for pyusb: apt-get install libusb-1.0-0")

    monkeypatch.setattr(devices, "list_usb_cameras", no_backend)
    sec = devices.usb_cameras()
    assert sec == {
        "available": False,
        "devices": [],
        "note": "no libusb backend for pyusb: apt-get install libusb-1.0-0",
    }
    assert devices.v4l2_devices(str(tmp_path), str(tmp_path)) == {
        "available": True,
        "devices": [],
        "note": "none found",
    }
    text = devices.render({k: sec for k in devices.SECTIONS})
    assert text.count("unavailable: no libusb backend") == 4


def test_aravis_section_reports_missing_gi(monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "gi", None)
    sec = devices.aravis_cameras()
    assert sec["available"] is False and "PyGObject" in sec["note"]
