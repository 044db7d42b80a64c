"""LDM41/42 ASCII lines: the three output formats, no target, pattern validation."""

from __future__ import annotations

import pytest

from snrmon.drivers.errors import ParseError
from snrmon.drivers.rangefinder.ldm import parse_ldm
from snrmon.drivers.rangefinder.reading import RangeStatus


def test_decimal_format() -> None:
    r = parse_ldm(b"004.996", 3)
    assert r.range_m == pytest.approx(4.996) and r.quality is None and r.t_host_ns == 3


def test_signal_quality_format() -> None:
    r = parse_ldm("004.996 000985", 0)
    assert r.range_m == pytest.approx(4.996) and r.quality == 985


def test_hex_millimetres_format() -> None:
    assert parse_ldm(" 001384", 0).range_m == pytest.approx(4.996)


def test_hex_negative_is_twos_complement() -> None:
    assert parse_ldm(" FFFC18", 0).range_m == pytest.approx(-1.0)


def test_e15_no_target_other_codes_error() -> None:
    assert parse_ldm("E15", 0).status is RangeStatus.NO_TARGET
    assert parse_ldm("E03", 0).status is RangeStatus.ERROR


def test_refused_command_is_not_a_reading() -> None:
    assert parse_ldm("?", 0) is None


@pytest.mark.parametrize("line", ["4.99x", "004.996 002000", "E1", "hello", b"\xff\xfe"])
def test_bad_lines_are_parse_errors(line) -> None:
    with pytest.raises(ParseError):
        parse_ldm(line, 0)
