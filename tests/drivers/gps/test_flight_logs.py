"""The field's own flight logs (tests/data/field-formats, real files of other people's drones,
autopilots and receivers): each kind detected from its content, and each reader checked against
an independent rendering of the same flight (the same flight's other log, the library's own
reading, the file's own lines or bytes)."""

from __future__ import annotations

import gzip
import re
import struct
from datetime import UTC, datetime, timedelta
from pathlib import Path

import numpy as np
import pytest

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.flight_log import detect_format, read_flight_log

KINDS = {
    "ardupilot/wlichon-mavflood-012428.tlog.gz": "tlog",
    "ardupilot/wlichon-mavflood-012428.BIN.gz": "dataflash",
    "px4-ulog/pyulog-sample_log_small.ulg.gz": "ulog",
    "px4-ulog/pyulog-sample_px4_events.ulg.gz": "ulog",
    "ublox/pyubx2-pygpsdata-MIXED.log": "ubx",
    "ublox/pyubx2-pygpsdata-NAV.log": "ubx",
    "ublox/pynmeagps-pygpsdata-um981.log": "nmea",
    "ublox/pynmeagps-unicore_nmea.log": "nmea",
    "dji-srt/air2s.srt": "dji_srt",
    "dji-srt/mavic_pro.SRT": "dji_srt",
    "dji-srt/old_format.SRT": "dji_srt",
    "dji-srt/p4_rtk.SRT": "dji_srt",
}


@pytest.fixture(scope="module")
def field(shared_data, tmp_path_factory) -> dict[str, Path]:
    """Every field file, the gzipped ones decompressed, under a name that says nothing of its
    kind (detection reads the content)."""
    folder = tmp_path_factory.mktemp("field")
    out = {}
    for i, name in enumerate(KINDS):
        data = (shared_data / "field-formats" / name).read_bytes()
        if name.endswith(".gz"):
            data = gzip.decompress(data)
        path = folder / f"log{i}.dat"
        path.write_bytes(data)
        out[name.removesuffix(".gz")] = path
    return out


def test_every_kind_is_detected_from_its_content(field, shared_data, tmp_path):
    for name, path in field.items():
        assert detect_format(path) == KINDS[name + (".gz" if name + ".gz" in KINDS else "")], name
    csv = tmp_path / "flight.bin"
    csv.write_bytes(gzip.decompress((shared_data / "dji-airdata" / "air-2s.csv.gz").read_bytes()))
    assert detect_format(csv) == "dji_csv"
    assert detect_format(shared_data / "nmea" / "nmea-rtk.log") == "nmea"
    junk = tmp_path / "notes.csv"
    junk.write_text("a,b\n1,2\n")
    with pytest.raises(ParseError, match="not a flight log snrmon reads"):
        detect_format(junk)


def _metres(lat0, lat1, lon0, lon1):
    north = (lat1 - lat0) * 111_320.0
    east = (lon1 - lon0) * 111_320.0 * np.cos(np.radians(lat0))
    return np.hypot(north, east)


def test_tlog_against_the_dataflash_log_of_the_same_flight(field):
    """The ground station's tlog (the autopilot's fused position on its SYSTEM_TIME UTC) and
    the autopilot's own DataFlash log (the receiver's fixes on GPS week time): at every tlog
    fix, the DataFlash track at the same UTC is within 10 cm (measured: 5 cm; the drone moves
    at up to 0.5 m/s, so a 0.1 s error in either time would show as 5 cm more)."""
    tlog = read_flight_log("tlog", field["ardupilot/wlichon-mavflood-012428.tlog"])
    bin_ = read_flight_log("dataflash", field["ardupilot/wlichon-mavflood-012428.BIN"])
    assert (len(tlog.fixes), len(bin_.fixes)) == (56, 244)
    assert tlog.dropped == 1  # the first position came before any GPS_RAW_INT: not a fix
    bu = np.array([f.utc.timestamp() for f in bin_.fixes])
    for f in tlog.fixes:
        u = f.utc.timestamp()
        assert bu[0] <= u <= bu[-1]
        lat = np.interp(u, bu, [b.lat_deg for b in bin_.fixes])
        lon = np.interp(u, bu, [b.lon_deg for b in bin_.fixes])
        assert _metres(lat, f.lat_deg, lon, f.lon_deg) < 0.10, f.utc
    # The ground station received each position 0.31 s after its UTC: measured and said.
    assert tlog.details["clock_offset_s"] == pytest.approx(0.311, abs=0.01)
    assert "received +0.311 s after the fix's UTC" in tlog.notes[0]


def test_dataflash_utc_is_gps_week_time_less_the_leap_seconds(field):
    from pymavlink import DFReader

    from snrmon.drivers.gps.dataflash import gps_time_to_utc

    reader = DFReader.DFReader_binary(str(field["ardupilot/wlichon-mavflood-012428.BIN"]))
    first = reader.recv_match(type=["GPS"])
    # pymavlink's own clock from the same message (it subtracts 18 s)
    ours = gps_time_to_utc(first.GWk, first.GMS).timestamp()
    assert ours == pytest.approx(first._timestamp, abs=1e-6)
    assert gps_time_to_utc(1000, 0) == datetime(
        1999, 3, 6, 23, 59, 47, tzinfo=UTC
    )  # week 1000 less 13 s


def test_ulog_against_pyulogs_own_reading(field):
    from pyulog import ULog

    for name, expect, dropped in (
        ("px4-ulog/pyulog-sample_log_small.ulg", 32, 0),
        # PX4 SITL: 146 messages before the simulated receiver locks, then 437 fixes
        ("px4-ulog/pyulog-sample_px4_events.ulg", 437, 146),
    ):
        log = read_flight_log("ulog", field[name])
        data = ULog(str(field[name]), ["vehicle_gps_position"]).data_list[0].data
        ok = data["fix_type"] >= 2
        lat = data["lat"] * 1e-7 if "lat" in data else data["latitude_deg"]
        assert (len(log.fixes), log.dropped) == (expect, dropped) == (ok.sum(), (~ok).sum())
        assert [f.lat_deg for f in log.fixes] == pytest.approx(list(lat[ok]), abs=1e-12)
        utc = [f.utc.timestamp() for f in log.fixes]
        assert utc == pytest.approx(list(data["time_utc_usec"][ok] / 1e6), abs=1e-6)


def _nav_pvt_frames(data: bytes):
    """UBX NAV-PVT payloads found by their sync bytes, class 0x01, id 0x07 and checksum (the
    u-blox interface description), decoded here without pyubx2."""
    out = []
    at = data.find(b"\xb5\x62\x01\x07")
    while at >= 0:
        (length,) = struct.unpack_from("<H", data, at + 4)
        body = data[at + 2 : at + 6 + length]
        a = b = 0
        for x in body:
            a, b = (a + x) & 0xFF, (b + ((a + x) & 0xFF)) & 0xFF
        if data[at + 6 + length : at + 8 + length] == bytes([a, b]) and length == 92:
            p = data[at + 6 : at + 6 + 92]
            year, month, day, hour, minute, sec, valid = struct.unpack_from("<HBBBBBB", p, 4)
            (nano,) = struct.unpack_from("<i", p, 16)
            fix_type, flags, _, num_sv = struct.unpack_from("<BBBB", p, 20)
            lon, lat, _height, h_msl = struct.unpack_from("<iiii", p, 24)
            out.append(
                {
                    "utc": datetime(year, month, day, hour, minute, sec, tzinfo=UTC)
                    + timedelta(microseconds=nano / 1000),
                    "ok": fix_type in (2, 3, 4) and flags & 1 and valid & 3 == 3,
                    "lat": lat * 1e-7,
                    "lon": lon * 1e-7,
                    "h_msl_m": h_msl / 1000,
                    "sats": num_sv,
                }
            )
        at = data.find(b"\xb5\x62\x01\x07", at + 1)
    return out


def test_ubx_against_pyubx2_and_a_byte_level_decode(field):
    from pyubx2 import UBX_PROTOCOL, UBXReader

    for name in ("ublox/pyubx2-pygpsdata-MIXED.log", "ublox/pyubx2-pygpsdata-NAV.log"):
        log = read_flight_log("ubx", field[name])
        frames = [f for f in _nav_pvt_frames(field[name].read_bytes()) if f["ok"]]
        assert len(log.fixes) == len(frames) > 0
        with field[name].open("rb") as fh:
            lib = [m for _, m in UBXReader(fh, protfilter=UBX_PROTOCOL) if m.identity == "NAV-PVT"]
        assert len(lib) == len(frames)
        for fix, frame, m in zip(log.fixes, frames, lib, strict=True):
            assert fix.utc == frame["utc"]
            assert fix.lat_deg == pytest.approx(frame["lat"], abs=1e-12) == m.lat
            assert fix.lon_deg == pytest.approx(frame["lon"], abs=1e-12) == m.lon
            assert fix.alt_msl_m == frame["h_msl_m"] and fix.sats == frame["sats"]
    assert len(read_flight_log("ubx", field["ublox/pyubx2-pygpsdata-MIXED.log"]).fixes) == 39


def test_unicore_high_precision_sentences_against_their_fields(field):
    """$GNRMCH (a date, so a UTC) is a fix with the sentence's 8-decimal minutes; $GNGGAH
    decodes as GGA (its epoch has no date in the file: no UTC, not placed)."""
    from snrmon.drivers.gps.nmea import NmeaAssembler

    path = field["ublox/pynmeagps-unicore_nmea.log"]
    (fix,) = read_flight_log("nmea", path).fixes
    line = next(ln for ln in path.read_text().splitlines() if ln.startswith("$GNRMCH"))
    f = line.split(",")
    assert fix.utc == datetime.strptime(f[9] + f[1], "%d%m%y%H%M%S.%f").replace(tzinfo=UTC)
    assert fix.lat_deg == pytest.approx(int(f[3][:2]) + float(f[3][2:]) / 60, abs=1e-12)
    assert fix.lon_deg == pytest.approx(int(f[5][:3]) + float(f[5][3:]) / 60, abs=1e-12)
    gga = next(ln for ln in path.read_text().splitlines() if ln.startswith("$GNGGAH"))
    (g,) = NmeaAssembler().feed(gga, 0)
    g_f = gga.split(",")
    assert g.lat_deg == pytest.approx(int(g_f[2][:2]) + float(g_f[2][2:]) / 60, abs=1e-12)
    assert (g.alt_msl_m, g.sats, g.fix_quality) == (float(g_f[9]), int(g_f[7]), int(g_f[6]))


_SRT_DATE = re.compile(r"(\d{4})[-.](\d+)[-.](\d+) (\d+):(\d+):(\d+)(?:,(\d+),(\d+))?")


def _srt_blocks(path: Path) -> list[tuple[datetime, float, float]]:
    """(local time, lat, lon) of each block with a non-zero position, read from the file's
    own lines: line by line, not by the reader's patterns."""
    out = []
    when = lat = lon = None
    for line in [*path.read_text().splitlines(), ""]:
        if not line.strip():
            if when is not None and lat is not None and (lat, lon) != (0.0, 0.0):
                out.append((when, lat, lon))
            when = lat = lon = None
            continue
        m = _SRT_DATE.search(line)
        if m:
            y, mo, d, h, mi, s = map(int, m.groups()[:6])
            us = int(m[7]) * 1000 + int(m[8]) if m[7] else 0
            when = datetime(y, mo, d, h, mi, s, us, tzinfo=UTC)
        if "[latitude:" in line:
            lat = float(line.split("[latitude:")[1].split("]")[0])
            lon = float(line.split("[longitude:")[1].split("]")[0])
        elif line.startswith("GPS("):
            lon_s, lat_s = line[4:].split(")")[0].split(",")[:2]
            lat, lon = float(lat_s), float(lon_s)
    return out


@pytest.mark.parametrize("name", ["air2s.srt", "mavic_pro.SRT", "old_format.SRT"])
def test_srt_against_its_own_lines(field, name):
    log = read_flight_log("dji_srt", field[f"dji-srt/{name}"])
    assert log.local_time
    blocks = _srt_blocks(field[f"dji-srt/{name}"])
    ours = {(f.utc, f.lat_deg, f.lon_deg) for f in log.fixes}
    assert ours <= set(blocks)
    # every block but the repeats of one second (the older drones write two blocks for some
    # seconds; the second is off the log's 1 s clock and left out, and counted)
    assert len(ours) + log.clock.outliers == len(blocks)
    assert all(f.alt_msl_m is None for f in log.fixes)  # no abs_alt: heights are not MSL


def test_an_srt_without_dates_is_refused(field):
    with pytest.raises(ParseError, match="no date and time in its 55 subtitle blocks"):
        read_flight_log("dji_srt", field["dji-srt/p4_rtk.SRT"])
