"""Device health in the camera header: the console on a real Session fed by the simulated field
kit (a shared-memory camera, an LDM rangefinder and an NMEA GPS on pseudo-terminals). The
rangefinder's port vanishes (its plug pulled) and the camera stalls; the header turns red
saying what is lost and for how long, never shows the rangefinder's last value as live, and
the losses go into the recording's events and the status file."""

from __future__ import annotations

import time

import pytest
from PySide6.QtCore import QSettings

from snrmon.acquisition.record.reader import open_session
from snrmon.acquisition.runtime.session import Session
from snrmon.acquisition.stops.detector import StopConfig
from snrmon.gui import theme as th
from snrmon.gui.app import console_application
from snrmon.gui.main_window import ConsoleWindow
from snrmon.gui.status_file import console_state
from tests.helpers import field_devices, field_session_config

RANGE_M = 150.0


@pytest.fixture
def kit(tmp_path):
    name = f"snrmon-health-{time.monotonic_ns() % 10**9}"
    with field_devices(name, seed=5, range_m=RANGE_M, lrf_hz=20.0) as (producer, lrf, gps):
        config = field_session_config(name, lrf, gps)
        session = Session(config, stop_config=StopConfig(steady_s=1.0, min_readings=3))
        session.pipelines["cam"].device.stale_after_s = 0.5
        try:
            yield session, producer, lrf
        finally:
            session.stop()


def test_a_lost_rangefinder_and_a_stalled_camera_turn_the_header_red(qtbot, kit, tmp_path):
    session, producer, lrf = kit
    console_application(headless=True)
    settings = QSettings(str(tmp_path / "console.ini"), QSettings.Format.IniFormat)
    win = ConsoleWindow(session, settings=settings)
    qtbot.addWidget(win)
    win.set_size(1400, 900)
    session.start()
    session.start_recording(tmp_path / "day.h5")
    win.show()
    header = win.panels["cam"].header
    live = f"LRF {RANGE_M:.1f}"
    qtbot.waitUntil(lambda: live in header.text(), timeout=15_000)
    assert not header.alarm and "LOST" not in header.text()

    lrf.unplug()  # the rangefinder's plug pulled: its port vanishes
    qtbot.waitUntil(lambda: "LRF lost" in header.text(), timeout=15_000)
    text = header.text()
    state = header.tiles["state"]
    assert "LRF LOST" in state.value.text() and state.verdict == "lost", text
    assert live not in text  # its last value is not shown as if it were live
    assert header.alarm and th.ALARM in header.styleSheet()
    assert th.ALARM in state.value.styleSheet()
    # and for how long: the seconds since its last reading grow
    first = session.status().cameras["cam"].lost_kind("LRF").for_s
    qtbot.waitUntil(
        lambda: session.status().cameras["cam"].lost_kind("LRF").for_s >= first + 1.0,
        timeout=10_000,
    )
    qtbot.waitUntil(
        lambda: (
            f"LRF lost {session.status().cameras['cam'].lost_kind('LRF').for_s:.0f} s"
            in header.text()
        ),
        timeout=5_000,
    )

    producer.pause()  # the camera stalls: its header is no longer green "tracking"
    qtbot.waitUntil(lambda: "camera" in state.value.text(), timeout=15_000)
    assert state.value.text() == "camera + LRF LOST"
    assert "camera stale" in state.note.text() and state.verdict == "lost"
    status = console_state(win)
    cam = status["cameras"]["cam"]
    assert {d["kind"] for d in cam["lost"]} == {"camera", "LRF"}
    assert any(a.startswith("cam: stale") for a in status["alarms"]), status["alarms"]

    producer.resume()
    qtbot.waitUntil(lambda: "camera" not in state.value.text(), timeout=15_000)
    lrf.replug()
    qtbot.waitUntil(lambda: not header.alarm, timeout=20_000)
    assert "LOST" not in header.text()
    session.stop_recording()
    with open_session(tmp_path / "day.h5") as f:
        events = f.event_list()
    # the devices' own state changes, each way once (the session's one record of a loss)
    lost = [
        (e["payload"]["device"], e["payload"]["state"])
        for e in events
        if e["kind"] == "device_lost"
    ]
    back = {e["payload"]["device"] for e in events if e["kind"] == "device_back"}
    assert ("cam", "stale") in lost and any(name == "lrf" for name, _ in lost), lost
    assert back == {"cam", "lrf"}
