"""Property-based fuzzing of every line parser: only the driver's ParseError ever escapes, and a
mutated checksum is always rejected."""

from __future__ import annotations

import contextlib

from hypothesis import given, settings
from hypothesis import strategies as st

from snrmon.drivers.errors import ChecksumError, ParseError
from snrmon.drivers.gps.gpsd import fix_from_tpv
from snrmon.drivers.gps.nmea import NmeaAssembler, nmea_checksum
from snrmon.drivers.rangefinder.ldm import parse_ldm
from snrmon.drivers.rangefinder.trupulse import parse_trupulse

VALID_NMEA = [
    "$GPGGA,092750.000,5321.6802,N,00630.3372,W,1,8,1.03,61.7,M,55.2,M,,*76",
    "$GPRMC,113258,A,3238.9148,N,10822.4466,W,005.3,247.1,181022,009.3,E*6B",
    "$GNGGA,132819.60,4134.49795459,N,09345.03431408,W,2,10,0.9,278.161,M,-31.442,M,6.6,0133*6A",
    "$GPGSA,A,3,02,05,11,12,18,20,25,29,,,,,1.4,1.1,0.9*3D",
    "$GPVTG,0.00,T,,M,0.000,N,0.000,K,N*32",
]
VALID_TP = ["$PLTIT,HV,11.80,M,0.00,D,3.70,D,11.80,M*63", "$PLTIT,HV,,,0.00,D,29.10,D,,*5D"]
FUZZ = settings(max_examples=300, deadline=None, derandomize=True)


def _all_parsers(data: bytes) -> None:
    for parse in (
        lambda b: NmeaAssembler(allow_no_checksum=True).feed(b, 0),
        lambda b: NmeaAssembler().feed(b, 0),
        lambda b: parse_trupulse(b, 0),
        lambda b: parse_ldm(b, 0),
    ):
        with contextlib.suppress(ParseError):
            parse(data)


@FUZZ
@given(st.binary(max_size=120))
def test_arbitrary_bytes_raise_only_parse_error(data: bytes) -> None:
    _all_parsers(data)
    _all_parsers(b"$" + data)


@st.composite
def mutated(draw, lines: list[str]) -> bytes:
    line = bytearray(draw(st.sampled_from(lines)).encode())
    for _ in range(draw(st.integers(1, 4))):
        op = draw(st.sampled_from(["flip", "insert", "delete"]))
        i = draw(st.integers(0, len(line) - 1))
        if op == "flip":
            line[i] = draw(st.integers(0, 255))
        elif op == "insert":
            line.insert(i, draw(st.integers(0, 255)))
        elif len(line) > 1:
            del line[i]
    return bytes(line)


@FUZZ
@given(mutated(VALID_NMEA + VALID_TP))
def test_mutated_sentences_raise_only_parse_error(data: bytes) -> None:
    _all_parsers(data)


@FUZZ
@given(st.sampled_from(VALID_NMEA + VALID_TP), st.integers(1, 255))
def test_mutated_checksum_always_rejected(line: str, delta: int) -> None:
    body = line[1 : line.rindex("*")]
    wrong = f"${body}*{nmea_checksum(body) ^ delta:02X}"
    parse = parse_trupulse if body.startswith("PLTIT") else NmeaAssembler().feed
    try:
        parse(wrong, 0)
    except ChecksumError:
        return
    raise AssertionError(f"accepted {wrong}")


@FUZZ
@given(
    st.dictionaries(
        st.sampled_from(["mode", "lat", "lon", "alt", "altMSL", "altHAE", "time", "status"]),
        st.one_of(st.none(), st.booleans(), st.integers(), st.floats(), st.text(max_size=30)),
    )
)
def test_gpsd_tpv_fields_raise_only_parse_error(tpv: dict) -> None:
    with contextlib.suppress(ParseError):
        fix_from_tpv({"class": "TPV", **tpv}, 0)
