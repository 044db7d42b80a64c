"""MAVLink GLOBAL_POSITION_INT + GPS_RAW_INT over UDP loopback (skipped without pymavlink)."""

from __future__ import annotations

import socket
import threading

import pytest

from snrmon.drivers.gps.mavlink import MavlinkGpsDevice

mavutil = pytest.importorskip("pymavlink.mavutil", reason="pymavlink not installed")


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def test_positions_and_fix_from_udp_stream() -> None:
    port = free_udp_port()
    dev = MavlinkGpsDevice(f"udpin:127.0.0.1:{port}")
    fixes = []
    done = threading.Event()
    dev.subscribe(lambda f: (fixes.append(f), len(fixes) >= 3 and done.set()))
    dev.open()
    out = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port}", source_system=1)
    stop = threading.Event()

    def send() -> None:
        k = 0
        while not stop.is_set():
            out.mav.gps_raw_int_send(
                1_557_846_000_000_000 + k * 100_000,
                3,
                481000000,
                115000000,
                520000,
                90,
                65535,
                0,
                0,
                14,
            )
            out.mav.global_position_int_send(
                k * 100, 481000000, 115000000, 520000, 20000, 0, 0, 0, 65535
            )
            k += 1
            stop.wait(0.05)

    sender = threading.Thread(target=send, daemon=True)
    sender.start()
    try:
        assert done.wait(5.0), f"status {dev.status()}"
    finally:
        stop.set()
        sender.join(2)
        dev.close()
        out.close()
    f = fixes[-1]
    assert (f.lat_deg, f.lon_deg, f.alt_msl_m) == (pytest.approx(48.1), pytest.approx(11.5), 520.0)
    assert f.fix_quality == 1 and f.sats == 14 and f.hdop == pytest.approx(0.9)
    assert f.utc is not None and f.utc.year == 2019
