"""The serial simulators speak their protocols on a pty (read here with plain pyserial)."""

from __future__ import annotations

import os
import warnings
from datetime import UTC, datetime

import pytest
import serial

from snrmon.sim.devices.faults import FaultInjector, corrupt_checksum
from snrmon.sim.devices.ldm_sim import LdmSimulator
from snrmon.sim.devices.line_sim import xor_checksum
from snrmon.sim.devices.nmea_sim import NmeaReplaySimulator, NmeaSimulator, gga_rmc
from snrmon.sim.devices.pty_port import BaudBudgetWarning, PtyPort
from snrmon.sim.devices.trupulse_sim import TruPulseSimulator, hv_sentence


def read_lines(path: str, n: int, timeout_s: float = 3.0, send: bytes = b"") -> list[bytes]:
    with serial.serial_for_url(path, baudrate=115200, timeout=timeout_s) as port:
        if send:
            port.write(send)
        return [port.readline() for _ in range(n)]


def test_gga_rmc_checksums_and_coordinates() -> None:
    gga, rmc = gga_rmc(datetime(2019, 5, 14, 15, 0, 1, 500000, tzinfo=UTC), -33.5, 151.25, 12.0)
    body = gga[1 : gga.index(b"*")].decode()
    assert gga.endswith(b"*" + xor_checksum(body).encode() + b"\r\n")
    assert b",150001.50,3330.0000000,S,15115.0000000,E,1," in gga
    assert b",140519,," in rmc


def test_nmea_sim_streams_at_rate_from_the_position_provider() -> None:
    with NmeaSimulator(lambda t: (10.0 + t, 20.0, 5.0), rate_hz=20, baud=115200) as sim:
        lines = read_lines(sim.path, 6)
    assert all(line.startswith((b"$GPGGA", b"$GPRMC")) for line in lines)
    assert sim.epochs >= 3


def test_baud_budget_warns_when_10hz_cannot_fit() -> None:
    with pytest.warns(BaudBudgetWarning, match="4800 baud"):
        NmeaSimulator(rate_hz=10, baud=4800).port.close()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        sim = NmeaSimulator(rate_hz=10, baud=19200)
        sim.port.close()
    assert 0.5 < sim.link_load < 1.0


def test_replay_strips_comments(shared_data) -> None:
    log = shared_data / "nmea" / "garmin15x.log"
    with NmeaReplaySimulator(log, lines_per_s=200) as sim:
        lines = read_lines(sim.path, 5)
    assert all(line.startswith(b"$") for line in lines) and not any(b"#" in x for x in lines)


def test_trupulse_answers_commands_and_fires() -> None:
    with TruPulseSimulator(lambda t: 451.0, unit="F", baud=38400) as sim:
        lines = read_lines(sim.path, 4, send=b"$DU,0\r\n$GO\r\n$XX\r\n$PLTIT,RQ,ID\r\n")
    assert lines[:3] == [b"$OK\r\n", b"$OK\r\n", hv_sentence(451.0, 5.0, 0.0, unit="M")]
    assert lines[3].startswith(b"$PLTIT,ID,TP360R")  # $XX got no answer, as the CR400 does


def test_trupulse_no_target() -> None:
    with TruPulseSimulator(lambda t: None, baud=38400) as sim:
        assert read_lines(sim.path, 2, send=b"$GO\r\n") == [b"$OK\r\n", b"$E01\r\n"]


def test_ldm_formats_and_refusal() -> None:
    with LdmSimulator(lambda t: 4.996) as sim:
        lines = read_lines(sim.path, 3, send=b"SD s\r\nDM\r\nSD h\r\nDM\r\nXY\r\n")
    assert lines == [b"004.996 000900\r\n", b" 001384\r\n", b"?\r\n"]


def test_port_vanishes_and_returns_at_the_same_path() -> None:
    port = PtyPort(baud=None)
    try:
        first = port.pts_path
        port.vanish()
        assert not os.path.exists(port.path)
        assert port.write(b"lost\r\n") == 0
        port.restore()
        assert os.path.realpath(port.path) == port.pts_path and port.pts_path
        with serial.serial_for_url(port.path, timeout=2) as s:
            port.write(b"back\r\n")
            assert s.readline() == b"back\r\n"
        assert first  # a new /dev/pts/N may or may not reuse the number; the path is what counts
    finally:
        port.close()


def test_fault_helpers() -> None:
    line = b"$GPVTG,0.00,T,,M,0.000,N,0.000,K,N*32\r\n"
    assert corrupt_checksum(line) != line and corrupt_checksum(line)[:-4] == line[:-4]
    f = FaultInjector(seed=1)
    f.truncate()
    (cut,) = f.apply(line)
    assert line.startswith(cut.rstrip(b"\r\n")) and len(cut) < len(line)
    f.silence()
    assert f.apply(line) == []
