"""DJI AirData CSV import: the altitude unit comes from the header."""

from __future__ import annotations

from datetime import UTC, datetime

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
