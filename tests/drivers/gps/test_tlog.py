"""MAVLink .tlog import: positions and their UTC, by the best source in the log."""

from __future__ import annotations

import struct
from datetime import UTC, datetime, timedelta

import pytest

pytest.importorskip("pymavlink")
from pymavlink.dialects.v20 import common as mavlink2

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.tlog import read_tlog
from snrmon.sim.flight import FlightPlan
from snrmon.sim.flight_logs import flight_epochs, write_tlog

U0 = datetime(2019, 5, 14, 15, 0, 7, 300000, tzinfo=UTC)


def _epochs(n: int = 30):
    times = [0.1 * k for k in range(n)]
    return flight_epochs(
        FlightPlan(), times, [U0 + timedelta(milliseconds=100 * k) for k in range(n)]
    )


def test_global_position_int_on_system_time(tmp_path):
    epochs = _epochs()
    log = read_tlog(write_tlog(tmp_path / "f.tlog", epochs, sats=11))
    assert log.utc_source == "system_time"
    assert log.counts["GLOBAL_POSITION_INT"] == len(epochs) and log.counts["SYSTEM_TIME"] == 3
    assert [f.utc for f in log.fixes] == [e.utc for e in epochs]
    for f, e in zip(log.fixes, epochs, strict=True):
        assert f.lat_deg == pytest.approx(e.lat_deg, abs=0.6e-7)  # degE7
        assert f.alt_msl_m == pytest.approx(e.alt_m, abs=0.0006)  # mm
        assert f.sats == 11 and f.hdop == 0.7 and f.fix_quality == 1
    assert log.fixes[5].t_host_ns == 500_000_000  # the log's own time from its first fix


def _write(path, messages) -> None:
    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    with open(path, "wb") as fh:
        for receipt_us, msg in messages:
            fh.write(struct.pack(">Q", receipt_us) + msg.pack(mav))


def test_gps_raw_int_time_when_there_is_no_system_time(tmp_path):
    unix = round(U0.timestamp() * 1e6)
    msgs = []
    for k in range(5):
        t = unix + 200_000 * k
        msgs.append(
            (
                t + 50_000,
                mavlink2.MAVLink_gps_raw_int_message(
                    t, 3, 323800000 + k, -1064800000, 1200000, 90, 120, 0, 0, 9
                ),
            )
        )
        msgs.append(
            (
                t + 60_000,
                mavlink2.MAVLink_global_position_int_message(
                    1000 + 200 * k, 323800000, -1064800000, 1200000, 0, 0, 0, 0, 0
                ),
            )
        )
    _write(tmp_path / "raw.tlog", msgs)
    log = read_tlog(tmp_path / "raw.tlog")
    assert log.utc_source == "gps_raw_int"
    assert [f.utc for f in log.fixes] == [U0 + timedelta(milliseconds=200 * k) for k in range(5)]
    assert [round(f.lat_deg * 1e7) for f in log.fixes] == [323800000 + k for k in range(5)]


def test_receipt_time_as_the_last_resort_and_no_position(tmp_path):
    receipt = round(U0.timestamp() * 1e6)
    gpi = mavlink2.MAVLink_global_position_int_message(
        1000, 323800000, -1064800000, 1200000, 0, 0, 0, 0, 0
    )
    _write(tmp_path / "gpi.tlog", [(receipt, gpi)])
    log = read_tlog(tmp_path / "gpi.tlog")
    assert log.utc_source == "tlog_receipt" and log.fixes[0].utc == U0
    _write(
        tmp_path / "none.tlog", [(receipt, mavlink2.MAVLink_heartbeat_message(1, 3, 0, 0, 0, 3))]
    )
    with pytest.raises(ParseError, match="no GLOBAL_POSITION_INT or GPS_RAW_INT"):
        read_tlog(tmp_path / "none.tlog")
    with pytest.raises(FileNotFoundError):
        read_tlog(tmp_path / "missing.tlog")


def _boot_log(path, boots, *, bad_system_time_at=None) -> list[datetime]:
    """A tlog of ``boots``: each a (first UTC, boot time of its first position in s, positions)
    at 5 Hz, a SYSTEM_TIME every second; returns the UTC of every position in order. The
    autopilot restarts between boots (its boot clock starts again); nothing is received in
    between (a gap of the link)."""
    msgs, utcs = [], []
    for b, (u_first, boot_s, n) in enumerate(boots):
        for k in range(n):
            utc = u_first + timedelta(milliseconds=200 * k)
            unix = round(utc.timestamp() * 1e6)
            boot_ms = round(boot_s * 1000) + 200 * k
            if k % 5 == 0:
                told = unix + (3600 * 10**6 if (b, k) == bad_system_time_at else 0)
                msgs.append((unix + 20_000, mavlink2.MAVLink_system_time_message(told, boot_ms)))
            gpi = mavlink2.MAVLink_global_position_int_message(
                boot_ms, 323800000 + 100 * b + k, -1064800000, 1200000, 0, 0, 0, 0, 0
            )
            msgs.append((unix + 30_000, gpi))
            utcs.append(utc)
    _write(path, msgs)
    return utcs


def test_a_reboot_maps_each_boot_through_its_own_system_time(tmp_path):
    """Boot 2 starts its clock at the same boot times as boot 1, 40 s of UTC later: nearest
    SYSTEM_TIME by boot time alone would put boot 2's positions on boot 1's UTC."""
    second = U0 + timedelta(seconds=40)
    utcs = _boot_log(tmp_path / "reboot.tlog", [(U0, 5.0, 30), (second, 5.0, 30)])
    log = read_tlog(tmp_path / "reboot.tlog")
    assert log.boots == 2 and log.utc_source == "system_time"
    assert [f.utc for f in log.fixes] == utcs
    assert (log.clock.gaps, log.clock.jumps, log.clock.outliers) == (1, 0, 0)


def test_a_wrong_system_time_is_set_aside_not_followed(tmp_path):
    utcs = _boot_log(tmp_path / "bad.tlog", [(U0, 5.0, 30)], bad_system_time_at=(0, 10))
    log = read_tlog(tmp_path / "bad.tlog")
    assert [f.utc for f in log.fixes] == utcs  # every position on the good pairings
    assert log.clock.outliers == 1 and "SYSTEM_TIME +3600.0 s off" in log.clock.examples[0]


def test_a_position_whose_time_jumps_is_left_out(tmp_path):
    """GPS_RAW_INT times of a receiver: one epoch a day early (a date rollover gone wrong)
    among 20 good ones is counted and left out; the others keep their order and time."""
    unix = round(U0.timestamp() * 1e6)
    msgs = []
    for k in range(21):
        t = unix + 200_000 * k - (86_400 * 10**6 if k == 12 else 0)
        gps = mavlink2.MAVLink_gps_raw_int_message(
            t, 3, 323800000 + k, -1064800000, 1200000, 90, 120, 0, 0, 9
        )
        msgs.append((unix + 200_000 * k + 50_000, gps))
    _write(tmp_path / "jump.tlog", msgs)
    log = read_tlog(tmp_path / "jump.tlog")
    assert log.utc_source == "gps_raw_int"
    assert [round(f.lat_deg * 1e7) for f in log.fixes] == [
        323800000 + k for k in range(21) if k != 12
    ]
    assert log.clock.outliers == 1 and "-86397.6 s off" in log.clock.examples[0]
