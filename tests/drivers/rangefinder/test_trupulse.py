"""TruPulse $PLTIT parsing: units to metres, quality digit, no target, checksums."""

from __future__ import annotations

import pytest

from snrmon.drivers.errors import ChecksumError, ParseError
from snrmon.drivers.rangefinder.reading import RangeStatus
from snrmon.drivers.rangefinder.trupulse import parse_trupulse


def test_metres_high_quality() -> None:
    r = parse_trupulse("$PLTIT,HV,11.80,M,0.00,D,3.70,D,11.80,M*63", 7)
    assert (r.range_m, r.horizontal_m, r.inclination_deg, r.quality, r.status) == (
        11.8,
        11.8,
        3.7,
        0,
        RangeStatus.OK,
    )
    assert r.t_host_ns == 7


def test_low_quality_digit_is_not_a_distance_digit() -> None:
    r = parse_trupulse("$PLTIT,HV,7.01,M,0.00,D,3.00,D,7.01,M*64", 0)
    assert r.range_m == pytest.approx(7.0) and r.quality == 1


def test_feet_converted_to_metres() -> None:
    r = parse_trupulse("$PLTIT,HV,18.00,F,185.20,D,6.90,D,18.00,F*66", 0)
    assert r.range_m == pytest.approx(18.0 * 0.3048) and r.azimuth_deg == pytest.approx(185.2)


def test_yards_converted_and_negative_inclination() -> None:
    body = "PLTIT,HV,10.00,Y,10.00,D,-42.90,D,10.00,Y"
    cs = 0
    for c in body.encode():
        cs ^= c
    r = parse_trupulse(f"${body}*{cs:02X}", 0)
    assert r.range_m == pytest.approx(9.144) and r.inclination_deg == pytest.approx(-42.9)


def test_inclination_only_shot_has_no_range() -> None:
    r = parse_trupulse("$PLTIT,HV,,,0.00,D,29.10,D,,*5D", 0)
    assert r.range_m is None and r.status is RangeStatus.NO_TARGET
    assert r.inclination_deg == pytest.approx(29.1)


def test_e01_is_no_target_other_errors_are_errors() -> None:
    assert parse_trupulse("$E01", 0).status is RangeStatus.NO_TARGET
    assert parse_trupulse("$E05", 0).status is RangeStatus.ERROR


def test_acknowledgements_are_not_readings() -> None:
    assert parse_trupulse("$OK", 0) is None
    assert parse_trupulse("$PLTIT,ID,TP200,1.02,*73", 0) is None


def test_manual_ml_example_has_a_wrong_checksum() -> None:
    with pytest.raises(ChecksumError):
        parse_trupulse("$PLTIT,ML,8.10,Y,0.00,D,3.20,D,8.10,Y*74", 0)


@pytest.mark.parametrize(
    "line", ["PLTIT,HV", "$PLTIT,HV,11.80,M*00", "$GARBAGE", "$PLTIT,HV,11.80,M,0.00,D,3.70,D"]
)
def test_malformed_lines_are_parse_errors(line: str) -> None:
    with pytest.raises(ParseError):
        parse_trupulse(line, 0)
