"""``snrmon gps-import SESSION LOG`` with the field's own files: each kind imports with the
outcome its provenance says, and an import never damages the session: only fixes are written,
an import that would keep fewer than half of the log's fixes is refused with ``/gps``
unchanged and says why, an out-of-order log is sorted and says how many lines moved."""

from __future__ import annotations

import gzip
import json
import random
import struct
import sys
from datetime import UTC, datetime, timedelta

import h5py
import pytest

from snrmon.acquisition.record.gps_import import gps_source
from snrmon.cli import main
from snrmon.drivers.gps.flight_log import detect_format, read_flight_log
from tests.acquisition.record.test_gps_import import bare_session

FIELD = {
    # file: (fixes written, the drone's local time - UTC in hours where it has one)
    "ardupilot/wlichon-mavflood-012428.tlog.gz": (56, None),
    "ardupilot/wlichon-mavflood-012428.BIN.gz": (244, None),
    "px4-ulog/pyulog-sample_log_small.ulg.gz": (32, None),
    "px4-ulog/pyulog-sample_px4_events.ulg.gz": (437, None),
    "ublox/pyubx2-pygpsdata-MIXED.log": (39, None),
    "ublox/pyubx2-pygpsdata-NAV.log": (1, None),
    "ublox/pynmeagps-pygpsdata-um981.log": (2, None),
    "ublox/pynmeagps-unicore_nmea.log": (1, None),
    "dji-srt/air2s.srt": (17, 2.0),  # Barcelona in August: UTC+02:00
    "dji-srt/mavic_pro.SRT": (463, 10.0),  # Queensland: UTC+10:00
    "dji-srt/old_format.SRT": (463, 10.0),
}


def _field_file(shared_data, tmp_path, name: str):
    data = (shared_data / "field-formats" / name).read_bytes()
    if name.endswith(".gz"):
        data = gzip.decompress(data)
    path = tmp_path / name.split("/")[-1].removesuffix(".gz")
    path.write_bytes(data)
    return path


def _session_around(path, log, *, hours: float = 0.0, before_s: float = 5.0):
    """A session with no GPS whose frames span the log's fixes (its local time less
    ``hours`` where it is in local time), ``before_s`` on either side."""
    fixes = read_flight_log(detect_format(log), log).fixes
    start = fixes[0].utc - timedelta(hours=hours) - timedelta(seconds=before_s)
    span = (fixes[-1].utc - fixes[0].utc).total_seconds() + 2 * before_s
    bare_session(path, start, span)


@pytest.mark.parametrize("name", list(FIELD))
def test_every_field_file_imports_as_its_provenance_says(name, shared_data, tmp_path, capsys):
    log = _field_file(shared_data, tmp_path, name)
    written, hours = FIELD[name]
    session = tmp_path / "s.h5"
    _session_around(session, log, hours=hours or 0.0)
    assert main(["gps-import", str(session), str(log), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["fixes_written"] == written and result["fixes_outside"] == 0
    with h5py.File(session, "r") as f:
        gps = f["gps"][()]
    assert len(gps) == written
    assert (gps["fix_quality"] > 0).all()
    assert not ((gps["lat_deg"] == 0) & (gps["lon_deg"] == 0)).any()  # never at 0 N 0 E
    if hours is not None:
        assert result["utc_offset_s"] == hours * 3600
        assert "from the session's own UTC" in result["utc_source"]


def test_an_srt_with_the_offset_given_and_one_without_dates(shared_data, tmp_path, capsys):
    log = _field_file(shared_data, tmp_path, "dji-srt/air2s.srt")
    session = tmp_path / "s.h5"
    _session_around(session, log, hours=2.0)
    assert main(["gps-import", str(session), str(log), "--utc-offset", "+02:00"]) == 0
    out = capsys.readouterr().out
    assert "17 of 17 fixes" in out and "the drone's local time - UTC+02:00 (--utc-offset)" in out
    # A wrong zone puts it an hour outside the session: refused, /gps as it was (imported).
    assert main(["gps-import", str(session), str(log), "--utc-offset", "+01:00"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "the log starts 3595.0 s after the session ends" in err[0]
    with h5py.File(session, "r") as f:
        assert len(f["gps"]) == 17 and "UTC+02:00" in f["gps"].attrs["import_json"]
    p4 = _field_file(shared_data, tmp_path, "dji-srt/p4_rtk.SRT")
    assert main(["gps-import", str(session), str(p4)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{p4}: no date and time in its 55 subtitle blocks" in err[0]


def _tlog(path, messages) -> None:
    pytest.importorskip("pymavlink")
    from pymavlink.dialects.v20 import common as mavlink2

    mav = mavlink2.MAVLink(None, srcSystem=1, srcComponent=1)
    with open(path, "wb") as fh:
        for receipt_us, make in messages:
            fh.write(struct.pack(">Q", receipt_us) + make(mavlink2).pack(mav))


U0 = datetime(2024, 6, 1, 12, 0, 0, tzinfo=UTC)


def _autopilot(n: int, *, lock_at: int, first_before_raw: bool, behind_s: float = 0.0):
    """An autopilot's stream at 5 Hz: a SYSTEM_TIME every second (its UTC ``behind_s`` behind
    the ground station's receipt), GLOBAL_POSITION_INT at 0 N 0 E until the receiver locks at
    epoch ``lock_at`` (GPS_RAW_INT fix_type 0 before, 3 after), optionally one position before
    any GPS_RAW_INT."""
    msgs = []
    for k in range(n):
        unix = round((U0 + timedelta(milliseconds=200 * k)).timestamp() * 1e6)
        boot = 10_000 + 200 * k
        receipt = unix + round(behind_s * 1e6) + 20_000
        locked = k >= lock_at
        lat, lon = (473977420 + k, 85455940) if locked else (0, 0)
        if k % 5 == 0:
            msgs.append((receipt, lambda m, t=unix, b=boot: m.MAVLink_system_time_message(t, b)))
        gpi = lambda m, b=boot, la=lat, lo=lon: m.MAVLink_global_position_int_message(  # noqa: E731
            b, la, lo, 488000 if la else 0, 0, 0, 0, 0, 0
        )
        raw = lambda m, b=boot, la=lat, lo=lon, ok=locked: m.MAVLink_gps_raw_int_message(  # noqa: E731
            b * 1000, 3 if ok else 0, la, lo, 488000, 90, 120, 0, 0, 12 if ok else 0
        )
        if k == 0 and first_before_raw:
            msgs.append((receipt, gpi))
            msgs.append((receipt + 1000, raw))
        else:
            msgs.append((receipt, raw))
            msgs.append((receipt + 1000, gpi))
    return msgs


def test_a_tlog_that_never_locks_is_refused_and_the_session_kept(tmp_path, capsys):
    """It imported as '140 of 140 written' at 0 N 0 E before."""
    log = tmp_path / "nolock.tlog"
    _tlog(log, _autopilot(140, lock_at=10**6, first_before_raw=True))
    session = tmp_path / "s.h5"
    bare_session(session, U0 - timedelta(seconds=5), 40)
    assert main(["gps-import", str(session), str(log)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{log}: no GPS fix in the log: 140 positions" in err[0]
    with h5py.File(session, "r") as f:
        assert len(f["gps"]) == 0 and "source" not in f["gps"].attrs


def test_a_tlog_that_locks_late_has_no_row_at_zero_and_its_clock_offset_said(tmp_path, capsys):
    """The first position came before any GPS_RAW_INT (it was written at 0,0 as quality 1),
    the next 29 while the receiver had no fix; the autopilot's clock 17 s behind the ground
    station's."""
    log = tmp_path / "late.tlog"
    _tlog(log, _autopilot(100, lock_at=30, first_before_raw=True, behind_s=17.0))
    session = tmp_path / "s.h5"
    bare_session(session, U0 - timedelta(seconds=5), 40)
    assert main(["gps-import", str(session), str(log)]) == 0
    out = capsys.readouterr().out
    assert "70 of 70 fixes" in out and "30 positions without a fix (before the lock)" in out
    assert "received +17.021 s after the fix's UTC" in out and "one of the two clocks" in out
    with h5py.File(session, "r") as f:
        gps = f["gps"][()]
        meta = json.loads(f["gps"].attrs["import_json"])
    assert len(gps) == 70 and (gps["lat_deg"] > 47).all() and (gps["fix_quality"] == 1).all()
    assert meta["details"]["clock_offset_s"] == pytest.approx(17.021, abs=1e-3)
    first = datetime.fromtimestamp(int(gps["fix_utc_ns"][0]) / 1e9, UTC)
    assert first == U0 + timedelta(milliseconds=200 * 30)  # the first locked epoch


def _nmea_lines(shared_data) -> list[bytes]:
    raw = (shared_data / "nmea" / "nmea-rtk.log").read_bytes().splitlines()
    return [ln for ln in raw if ln.strip() and not ln.startswith(b"#")]


@pytest.mark.parametrize("order", ["reversed", "shuffled"])
def test_an_out_of_order_nmea_log_is_sorted_and_says_so(order, shared_data, tmp_path, capsys):
    """Before: a reversed log kept 1 fix of 427, a shuffled one 37 (as a jump-ridden clock)."""
    lines = _nmea_lines(shared_data)
    whole = read_flight_log("nmea", shared_data / "nmea" / "nmea-rtk.log").fixes
    if order == "reversed":
        lines = lines[::-1]
    else:
        random.Random(7).shuffle(lines)
    log = tmp_path / f"{order}.nmea"
    log.write_bytes(b"\r\n".join(lines))
    session = tmp_path / "s.h5"
    span = (whole[-1].utc - whole[0].utc).total_seconds()
    bare_session(session, whole[0].utc - timedelta(seconds=1), span + 2)
    assert main(["gps-import", str(session), str(log), "--json"]) == 0
    result = json.loads(capsys.readouterr().out)
    assert result["fixes_written"] == len(whole) == 122
    moved = result["details"]["lines_moved"]
    assert moved == (121 if order == "reversed" else moved) and moved > 60
    assert f"{moved} of 122 epochs moved" in result["notes"][0]
    with h5py.File(session, "r") as f:
        assert [int(u) for u in f["gps"]["fix_utc_ns"]] == sorted(
            round(x.utc.timestamp() * 1e9) for x in whole
        )


def test_a_log_outside_the_session_is_refused_and_the_live_stream_kept(
    shared_data, tmp_path, capsys
):
    """It wrote 0 fixes, emptied /gps and exited 0 before."""
    from tests.acquisition.session_factory import write_session

    s = write_session(tmp_path / "s.h5", ranges_m=(120.0,), hover_s=2.0, transit_s=1.0)
    with h5py.File(s.path, "r") as f:
        live = f["gps"][()]
    log = shared_data / "nmea" / "nmea-rtk.log"
    assert main(["gps-import", str(s.path), str(log), "--replace"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "the import would write 0 of the log's 122 fixes, refused: outside the session" in err[0]
    assert "s before the session starts (/gps unchanged)" in err[0]
    with h5py.File(s.path, "r") as f:
        assert f["gps"][()].tobytes() == live.tobytes() and "gps_live" not in f
    assert gps_source(s.path) == "live"


def test_old_flags_warn_once_and_format_forces_the_kind(shared_data, tmp_path, capsys):
    log = shared_data / "nmea" / "nmea-rtk.log"
    whole = read_flight_log("nmea", log).fixes
    session = tmp_path / "s.h5"
    bare_session(session, whole[0].utc, (whole[-1].utc - whole[0].utc).total_seconds())
    assert main(["gps-import", str(session), "--nmea", str(log)]) == 0
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [
        "snrmon gps-import: warning: --nmea LOG is deprecated: give the log after the session "
        "(its kind is detected; --format nmea forces it)"
    ]
    assert main(["gps-import", str(session), str(log), "--format", "dji_csv"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no latitude/longitude columns" in err[0]
    assert main(["gps-import", str(session), str(log), "--nmea", str(log)]) == 2
    assert "give one flight log" in capsys.readouterr().err
    with pytest.raises(SystemExit) as refused:
        main(["gps-import", str(session), str(log), "--utc-offset", "+15:00"])
    assert refused.value.code == 2
    assert "argument --utc-offset: must be local time - UTC" in capsys.readouterr().err


def test_a_missing_extra_is_named_in_one_line(shared_data, tmp_path, capsys, monkeypatch):
    log = _field_file(shared_data, tmp_path, "px4-ulog/pyulog-sample_log_small.ulg.gz")
    session = tmp_path / "s.h5"
    bare_session(session, datetime(2021, 4, 21, 6, 30, tzinfo=UTC), 60)
    monkeypatch.setitem(sys.modules, "pyulog", None)  # as if not installed
    assert main(["gps-import", str(session), str(log)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "pip install 'snrmon[flightlogs]'" in err[0]


def test_a_ulog_without_a_fix_is_refused(shared_data, tmp_path, capsys):
    """The PX4 SITL log cut at 30 % of its bytes (a logger stopped before the simulated
    receiver's first fix: 139 vehicle_gps_position messages, all fix_type 0) is refused, the
    session untouched. (The whole file has 437 fixes after its first 146 messages: it imports.)"""
    whole = _field_file(shared_data, tmp_path, "px4-ulog/pyulog-sample_px4_events.ulg.gz")
    data = whole.read_bytes()
    log = tmp_path / "stopped-early.ulg"
    log.write_bytes(data[: int(0.3 * len(data))])
    session = tmp_path / "s.h5"
    bare_session(session, datetime(2024, 3, 18, 14, 49, tzinfo=UTC), 60)
    assert main(["gps-import", str(session), str(log)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert f"{log}: no GPS fix in the log (139 vehicle_gps_position messages, none with" in err[0]
    with h5py.File(session, "r") as f:
        assert len(f["gps"]) == 0 and "source" not in f["gps"].attrs
