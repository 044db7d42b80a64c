"""Each real receiver log decodes to the positions gpsd's golden output (.chk) gives for it."""

from __future__ import annotations

import json
from datetime import datetime

import pytest

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.nmea import NmeaAssembler

LOGS = ["garmin15x", "mtk-3301", "nmea-rtk", "skytraq-err", "ublox-f9p-hpnmea"]


def _key(lat: float, lon: float) -> tuple[float, float]:
    return round(lat, 7), round(lon, 7)


def golden_tpvs(path) -> list[dict]:
    out = []
    for line in path.read_text().splitlines():
        if line.startswith("{"):
            report = json.loads(line)
            if report.get("class") == "TPV" and "lat" in report:
                out.append(report)
    return out


@pytest.mark.parametrize("name", LOGS)
def test_log_positions_match_gpsd_golden_output(shared_data, name: str) -> None:
    log = shared_data / "nmea" / f"{name}.log"
    golden = golden_tpvs(log.with_suffix(".log.chk"))
    a = NmeaAssembler(allow_no_checksum=True)  # $POLYN and $STI carry no checksum
    fixes = []
    for raw in log.read_bytes().splitlines():
        if raw.strip() and not raw.startswith(b"#"):
            try:
                fixes += a.feed(raw, 0)
            except ParseError as exc:
                pytest.fail(f"{name}: {exc}")
    decoded = {_key(f.lat_deg, f.lon_deg): f for f in fixes if f.lat_deg is not None}
    with_fix = {k for k, f in decoded.items() if f.has_fix}
    gold = {_key(t["lat"], t["lon"]) for t in golden}
    # Every position gpsd reports is one we decoded; every fix we call valid gpsd reports too.
    # (gpsd also reports a quality-0 GGA's position as a 2D fix: we decode it but flag no fix.)
    assert gold <= set(decoded)
    assert with_fix <= gold
    if name == "skytraq-err":
        assert not gold and not fixes and a.counts.no_checksum == 6
    else:
        assert with_fix
    # The UTC we assemble (GGA time + RMC date) equals gpsd's where both have one.
    utcs: dict[tuple[float, float], set] = {}
    for f in fixes:
        if f.lat_deg is not None and f.utc is not None:
            utcs.setdefault(_key(f.lat_deg, f.lon_deg), set()).add(f.utc)
    timed = [t for t in golden if "time" in t and _key(t["lat"], t["lon"]) in utcs]
    for t in timed:
        gpsd_utc = datetime.fromisoformat(t["time"].replace("Z", "+00:00"))
        assert gpsd_utc in utcs[_key(t["lat"], t["lon"])]
    if name != "skytraq-err":
        assert timed


def test_log_proprietary_and_checksumless_counted(shared_data) -> None:
    a = NmeaAssembler(allow_no_checksum={"POLYN"})
    for raw in (shared_data / "nmea" / "mtk-3301.log").read_bytes().splitlines():
        if raw.strip() and not raw.startswith(b"#"):
            a.feed(raw, 0)
    assert a.counts.no_checksum == 3 and a.counts.proprietary >= 3


# ---------------------------------------------------------------- the log's clock


def test_receiver_clock_before_lock_is_left_out_not_sorted_in(shared_data) -> None:
    """mtk-3301 powers up on its real-time clock (1980-01-05, then 1980-01-12) and jumps to
    2008-08-23 with the almanac; a GGA between carries the previous RMC's date. The log's clock
    is the 2008 chain; the eight epochs before it are counted as outliers and left out (they
    were sorted to the front and set every fix's log time 28 years late)."""
    from snrmon.drivers.gps.nmea_log import read_nmea_log

    log = read_nmea_log(shared_data / "nmea" / "mtk-3301.log")
    assert log.clock is not None
    assert (log.clock.jumps, log.clock.outliers) == (3, 8)
    assert (
        "1980-01-05" in log.clock.examples[0]
        and "days off the log's clock" in (log.clock.examples[0])
    )
    assert {f.utc.date() for f in log.fixes} == {datetime(2008, 8, 23).date()}
    assert [f.t_host_ns for f in log.fixes] == sorted(f.t_host_ns for f in log.fixes)
    assert log.fixes[0].t_host_ns == 0 and log.fixes[-1].t_host_ns < 10 * 10**9


def test_a_logger_gap_is_counted_and_keeps_every_epoch(shared_data) -> None:
    """nmea-rtk holds two stretches of a 10 Hz receiver ten minutes apart: one gap, no
    outlier, every epoch on its own UTC."""
    from snrmon.drivers.gps.nmea_log import read_nmea_log

    log = read_nmea_log(shared_data / "nmea" / "nmea-rtk.log")
    assert (log.clock.segments, log.clock.gaps, log.clock.jumps, log.clock.outliers) == (
        2,
        1,
        0,
        0,
    )
    assert len(log.fixes) == 122


def _checksummed(body: str) -> bytes:
    cs = 0
    for ch in body.encode():
        cs ^= ch
    return f"${body}*{cs:02X}\r\n".encode()


def test_a_real_log_across_midnight_keeps_its_clock(shared_data, tmp_path) -> None:
    """nmea-rtk's sentences re-stamped to start at 23:59:58 (checksums recomputed, RMC dates
    of the next day after midnight): every GGA just after midnight takes the next day even
    though the last RMC said the day before; the track is the original's, 10 h 31 min 38.4 s
    later, with no jump and no outlier."""
    from datetime import timedelta

    from snrmon.drivers.gps.nmea_log import read_nmea_log

    original = shared_data / "nmea" / "nmea-rtk.log"
    shift = timedelta(hours=10, minutes=31, seconds=38.4)  # 13:28:19.60 -> 23:59:58.00
    lines = []
    for raw in original.read_text().splitlines():
        if raw.startswith("#") or not raw.strip():
            continue
        fields = raw[1 : raw.index("*")].split(",")
        if fields[0][2:] in ("GGA", "RMC"):
            t = datetime.strptime("180320" + fields[1], "%d%m%y%H%M%S.%f") + shift
            fields[1] = f"{t:%H%M%S}.{t.microsecond // 10000:02d}"
            if fields[0][2:] == "RMC":
                fields[9] = f"{t:%d%m%y}"
        lines.append(_checksummed(",".join(fields)))
    shifted = tmp_path / "midnight.log"
    shifted.write_bytes(b"".join(lines))
    before, after = read_nmea_log(original), read_nmea_log(shifted)
    assert (after.clock.jumps, after.clock.outliers) == (0, 0)
    assert len(after.fixes) == len(before.fixes) == 122
    assert {f.utc.date() for f in after.fixes} == {
        datetime(2020, 3, 18).date(),
        datetime(2020, 3, 19).date(),
    }
    for a, b in zip(after.fixes, before.fixes, strict=True):
        assert (a.lat_deg, a.lon_deg, a.alt_msl_m) == (b.lat_deg, b.lon_deg, b.alt_msl_m)
        assert a.utc - b.utc == shift and a.t_host_ns == b.t_host_ns
