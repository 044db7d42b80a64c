"""DJI AirData CSV import: the altitude unit comes from the header."""

from __future__ import annotations

from datetime import UTC, datetime, timedelta

import pytest

from snrmon.drivers.errors import ParseError
from snrmon.drivers.gps.dji_csv import read_dji_csv

AIRDATA_FT = (
    "time(millisecond),datetime(utc),latitude,longitude,height_above_takeoff(feet),"
    "altitude_above_seaLevel(feet),compass_heading(degrees)\n"
    "0,2019-05-14 15:00:00,0.0,0.0,0,0,0\n"
    "100,2019-05-14 15:00:00.100,32.1234567,-106.7654321,10.0,4000.0,90\n"
    "200,2019-05-14 15:00:00.200,32.1234600,-106.7654300,11.0,4001.0,90\n"
)


def test_airdata_feet_converted_and_zero_rows_skipped(tmp_path) -> None:
    p = tmp_path / "flight.csv"
    p.write_text(AIRDATA_FT)
    fixes = read_dji_csv(p)
    assert len(fixes) == 2
    assert fixes[0].alt_msl_m == pytest.approx(4000.0 * 0.3048)
    assert fixes[0].lat_deg == pytest.approx(32.1234567) and fixes[0].t_host_ns == 100_000_000
    assert fixes[1].utc == datetime(2019, 5, 14, 15, 0, 0, 200000, tzinfo=UTC)


def test_airdata_meters(tmp_path) -> None:
    p = tmp_path / "flight.csv"
    p.write_text(AIRDATA_FT.replace("(feet)", "(meters)"))
    assert read_dji_csv(p)[0].alt_msl_m == pytest.approx(4000.0)


def test_phantomhelp_with_nul_bytes(tmp_path) -> None:
    p = tmp_path / "ph.csv"
    p.write_bytes(
        b"CUSTOM.updateTime,OSD.latitude,OSD.longitude,OSD.height [m]\n"
        b"2019/05/14 15:00:00.100,32.5,-106.5,12.0\x00\x00\n"
    )
    (f,) = read_dji_csv(p)
    assert (f.lat_deg, f.lon_deg, f.alt_msl_m) == (32.5, -106.5, None)  # height is not MSL
    assert f.utc == datetime(2019, 5, 14, 15, 0, 0, 100000, tzinfo=UTC)


@pytest.mark.parametrize(
    "text, match",
    [
        ("a,b\n1,2\n", "no latitude"),
        (AIRDATA_FT.replace("seaLevel(feet)", "seaLevel(furlongs)"), "unit"),
        (AIRDATA_FT.replace("32.1234600", "north"), "latitude"),
    ],
)
def test_bad_files_name_the_problem(tmp_path, text: str, match: str) -> None:
    p = tmp_path / "bad.csv"
    p.write_text(text)
    with pytest.raises(ParseError, match=match):
        read_dji_csv(p)


# ---------------------------------------------------------------- the real AirData export

FEET_M = 0.3048


def _gpx_points(path) -> list[tuple[float, float, float, datetime]]:
    """AirData's GPX of the flight, read with the standard library: (lat, lon, ele_m, utc)."""
    import gzip
    import xml.etree.ElementTree as ET

    ns = {"g": "http://www.topografix.com/GPX/1/1"}
    root = ET.fromstring(gzip.decompress(path.read_bytes()))
    out = []
    for pt in root.iterfind(".//g:trkpt", ns):
        when = datetime.strptime(pt.find("g:time", ns).text, "%Y-%m-%dT%H:%M:%S.%fZ")
        out.append(
            (
                float(pt.get("lat")),
                float(pt.get("lon")),
                float(pt.find("g:ele", ns).text),
                when.replace(tzinfo=UTC),
            )
        )
    return out


def _csv_rows(path) -> list[dict[str, str]]:
    import csv
    import gzip
    import io

    return list(csv.DictReader(io.StringIO(gzip.decompress(path.read_bytes()).decode("latin-1"))))


@pytest.fixture(scope="module")
def air2s(shared_data, module_tmp):
    import gzip

    folder = shared_data / "dji-airdata"
    csv_path = module_tmp("dji") / "air-2s.csv"
    csv_path.write_bytes(gzip.decompress((folder / "air-2s.csv.gz").read_bytes()))
    return csv_path, _csv_rows(folder / "air-2s.csv.gz"), _gpx_points(folder / "air-2s.gpx.gz")


@pytest.mark.slow
def test_real_export_every_gpx_point_is_a_fix_with_its_position_and_altitude(air2s) -> None:
    from snrmon.drivers.gps.dji_csv import read_dji_log

    path, _, gpx = air2s
    fixes = {(f.lat_deg, f.lon_deg): f for f in read_dji_log(path).fixes}
    assert len(gpx) == 10817
    for lat, lon, ele, _ in gpx:
        f = fixes[(lat, lon)]  # the same doubles: AirData prints the log's own digits
        assert f.alt_msl_m == pytest.approx(ele, rel=1e-7)  # GPX: metres, 7 decimals


def test_real_export_one_clock_across_its_gaps_no_row_moves_the_rest(air2s) -> None:
    """The log has 24 gaps in time(millisecond) and rows beside them up to 12.3 s off (the
    reader before this took the latest row's anchor: every fix 12.3 s late on the GPX). Every
    fix is on one anchor whose sub-second comes from AirData's time base, the first fix on its
    written second (the reader before this put it in the middle of the rounded seconds: 0.15 s
    late), and within 0.1 s of AirData's own GPX of the flight (an independent rendering with
    tenths of a second) at all 10,817 points (measured: 0.000 s)."""
    from snrmon.drivers.gps.dji_csv import read_dji_log

    path, _rows, gpx = air2s
    log = read_dji_log(path)
    assert log.clock is not None
    assert (log.clock.segments, log.clock.gaps, log.clock.jumps) == (25, 24, 0)
    assert log.clock.anchors == 1
    # The phase from the file alone: datetime(utc) changes at time(millisecond) = 0 mod 1000
    # at 1071 of its 1165 ticks.
    assert (log.tick_phase_ms, log.ticks, log.details["ticks_at_phase"]) == (0, 1165, 1071)
    fixes = {(f.lat_deg, f.lon_deg): f for f in log.fixes}
    offsets = [(fixes[(lat, lon)].utc - t).total_seconds() for lat, lon, _, t in gpx]
    assert max(abs(o) for o in offsets) <= 1e-3
    assert max(offsets) - min(offsets) < 1e-6  # one anchor: the GPX's own is one too
    assert "off the log's clock" in log.clock.describe()


def _rewritten(rows, path, datetime_of=None, position_from_ms=None):
    """The real export's rows written again, each row's ``datetime(utc)`` from
    ``datetime_of(row)`` and positions blanked (0, 0) before ``position_from_ms``."""
    import csv

    with path.open("w", newline="") as fh:
        w = csv.DictWriter(fh, list(rows[0]))
        w.writeheader()
        for r in rows:
            r = dict(r)
            if datetime_of is not None:
                r["datetime(utc)"] = datetime_of(r)
            if position_from_ms is not None and int(r["time(millisecond)"]) < position_from_ms:
                r["latitude"] = r["longitude"] = "0"
            w.writerow(r)
    return path


@pytest.mark.slow
def test_the_time_base_is_the_files_own_first_fix_not_a_constant(air2s, tmp_path) -> None:
    """AirData's time base puts the first row with a position on the second written in it:
    the real export with its positions blanked for its first 20 s more (its first fix 8.4 s
    later, at another phase of its second) moves every fix so that that row is on its second;
    the same export with its seconds written 0.1 s ahead of its GPX instead of 0.6 s (as the
    Mini 2 export writes them: the ticks move from 0 to 500 mod 1000) leaves every fix where it
    was: the ticks bound the anchor, they do not set it."""
    import math

    from snrmon.drivers.gps.dji_csv import read_dji_log

    path, rows, _ = air2s
    log = read_dji_log(path)
    before = {(f.lat_deg, f.lon_deg): f.utc for f in log.fixes}
    first = log.fixes[0]
    anchor = first.utc.timestamp() - first.t_host_ns / 1e9  # one anchor (the test above)

    late = read_dji_log(_rewritten(rows, tmp_path / "late.csv", position_from_ms=20_000))
    ff = next(r for r in rows if int(r["time(millisecond)"]) >= 20_000)
    second = datetime.strptime(ff["datetime(utc)"], "%Y-%m-%d %H:%M:%S").replace(tzinfo=UTC)
    assert late.fixes[0].utc == second  # the new first fix on its own second
    moved = {round((f.utc - before[(f.lat_deg, f.lon_deg)]).total_seconds(), 6) for f in late.fixes}
    assert moved == {round((second.timestamp() - anchor - 20.0) % 1.0, 6)}

    def ahead_by_0_1(r):
        u = math.floor(anchor + int(r["time(millisecond)"]) / 1000 + 0.1 + 1e-6)
        return f"{datetime.fromtimestamp(u, UTC):%Y-%m-%d %H:%M:%S}"

    lead = read_dji_log(_rewritten(rows, tmp_path / "lead.csv", datetime_of=ahead_by_0_1))
    assert lead.tick_phase_ms == 500
    assert {(f.lat_deg, f.lon_deg): f.utc for f in lead.fixes} == before


def test_a_clock_that_stopped_gets_a_new_anchor_after_its_gap(air2s, tmp_path) -> None:
    """The real export with the recorder's clock stopped over its 12.6 s gap (UTC went on 30 s
    more than time(millisecond) after it): the segment after the gap gets its own anchor, 30 s
    later; the part before keeps its own."""
    import csv

    from snrmon.drivers.gps.dji_csv import read_dji_log

    path, rows, _ = air2s
    before = {(f.lat_deg, f.lon_deg): f.utc for f in read_dji_log(path).fixes}
    header = list(rows[0])
    shifted = tmp_path / "paused.csv"
    with shifted.open("w", newline="") as fh:
        w = csv.DictWriter(fh, header)
        w.writeheader()
        for r in rows:
            if int(r["time(millisecond)"]) >= 920900:  # the rows after the 12.6 s gap
                u = datetime.strptime(r["datetime(utc)"], "%Y-%m-%d %H:%M:%S")
                r = {**r, "datetime(utc)": f"{u + timedelta(seconds=30):%Y-%m-%d %H:%M:%S}"}
            w.writerow(r)
    log = read_dji_log(shifted)
    assert log.clock.anchors == 2
    after = {(f.lat_deg, f.lon_deg): f.utc for f in log.fixes}
    for r in rows:
        key = (float(r["latitude"]), float(r["longitude"]))
        if key not in before or not any(key):
            continue
        late = 30.0 if int(r["time(millisecond)"]) >= 920900 else 0.0
        assert (after[key] - before[key]).total_seconds() == pytest.approx(late, abs=1e-6)


def test_a_second_drone_every_gpx_point_on_the_first_fix_time_base(shared_data) -> None:
    """The head of a DJI Mini 2 export (tests/data/dji-airdata): a fix from its first row and
    its seconds changing at 900 mod 1000 (the Air 2S export's at 0). Every point of AirData's
    GPX of the same flight is the reader's fix with the same position at the same UTC, to the
    millisecond. (A constant read off the Air 2S's ticks, 0.6 s before the new second, put this
    export 0.5 s early; the middle of the rounded seconds, 0.35 s early.)"""
    import xml.etree.ElementTree as ET

    from snrmon.drivers.gps.dji_csv import read_dji_log

    folder = shared_data / "dji-airdata"
    log = read_dji_log(folder / "mini-2-head.csv")
    assert (log.tick_phase_ms, log.ticks) == (900, 3)
    ns = {"g": "http://www.topografix.com/GPX/1/1"}
    gpx = ET.fromstring((folder / "mini-2-head.gpx").read_text() + "</trkseg></trk></gpx>")
    fixes = {(f.lat_deg, f.lon_deg): f.utc for f in log.fixes}
    points = list(gpx.iterfind(".//g:trkpt", ns))
    assert len(points) == 28 and len(fixes) == 30
    for pt in points:
        when = datetime.strptime(pt.find("g:time", ns).text, "%Y-%m-%dT%H:%M:%S.%fZ")
        utc = fixes[(float(pt.get("lat")), float(pt.get("lon")))]
        assert abs((utc - when.replace(tzinfo=UTC)).total_seconds()) < 1e-3, when
